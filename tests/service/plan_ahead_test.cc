// PlanInputs with pending_inputs: a plan computed while the plant still applies
// the inputs it committed to, over a real loopback server.

#include <cmath>
#include <string>
#include <vector>

#include "client/excite_client.h"
#include "gmock/gmock.h"
#include "google/rpc/error_details.pb.h"
#include "grpcpp/client_context.h"
#include "gtest/gtest.h"
#include "tests/service/pendulum_data.h"
#include "tests/service/service_fixture.h"

namespace excite::service {
namespace {

using ::excite::testing::BadRequestOf;
using ::excite::testing::PendulumConfig;
using ::excite::testing::PendulumTransitions;
using ::testing::HasSubstr;
using PlanAheadTest = ::excite::testing::ServiceTest;

std::vector<double> Repeated(const google::protobuf::RepeatedField<double>& values) {
  return {values.begin(), values.end()};
}

// The plan starts from the state the model predicts after the pending inputs
// (the Rollout RPC's mean there), and is the very plan a second session with the
// same data and seed makes from that state given as measured.
TEST_F(PlanAheadTest, PlansFromThePredictedStateAfterThePendingInputs) {
  for (v1::Strategy strategy : {v1::STRATEGY_REC, v1::STRATEGY_PA, v1::STRATEGY_ROI}) {
    SCOPED_TRACE(v1::Strategy_Name(strategy));
    const std::string ahead = Create("ahead", PendulumConfig(strategy)).name();
    const std::string measured = Create("measured", PendulumConfig(strategy)).name();
    for (const std::string& name : {ahead, measured})
      Add(name, {PendulumTransitions(30, 0, 3)});
    const std::vector<double> state = {0.1, -0.2};
    const std::vector<double> pending = {1.5, -0.5, 2.0};

    v1::RolloutRequest rollout;
    rollout.set_session(ahead);
    rollout.mutable_state()->Add(state.begin(), state.end());
    rollout.mutable_inputs()->Add(pending.begin(), pending.end());
    absl::StatusOr<v1::RolloutResponse> rolled = client_->Rollout(rollout);
    ASSERT_TRUE(rolled.ok()) << rolled.status();

    absl::StatusOr<v1::PlanInputsResponse> plan =
        client_->PlanInputs(ahead, state, pending);
    ASSERT_TRUE(plan.ok()) << plan.status();
    EXPECT_EQ(plan->start_step(), 3);
    ASSERT_EQ(plan->predicted_states_size(), 2 * plan->horizon());
    for (int d = 0; d < 2; ++d) {  // the rollout's mean after 3 steps (rows x_0 .. x_3)
      EXPECT_NEAR(plan->predicted_states(d), rolled->means(3 * 2 + d), 1e-12) << d;
    }
    const std::vector<double> start = {plan->predicted_states(0),
                                       plan->predicted_states(1)};
    absl::StatusOr<v1::PlanInputsResponse> same = client_->PlanInputs(measured, start);
    ASSERT_TRUE(same.ok()) << same.status();
    EXPECT_EQ(same->start_step(), 0);
    EXPECT_EQ(Repeated(plan->inputs()), Repeated(same->inputs()));
    EXPECT_EQ(plan->objective(), same->objective());
    // The session reports the plan with its start step.
    EXPECT_EQ(client_->GetSession(ahead)->last_plan().start_step(), 3);
    for (const std::string& name : {ahead, measured})
      ASSERT_TRUE(client_->DeleteSession(name).ok());
  }
}

// A model-free signal continues P samples later: with 2 pending inputs its plan
// is the plan without them moved on by 2.
TEST_F(PlanAheadTest, SignalsContinueAfterThePendingInputs) {
  for (v1::Strategy strategy :
       {v1::STRATEGY_PRBS, v1::STRATEGY_CHIRP, v1::STRATEGY_RANDOM}) {
    SCOPED_TRACE(v1::Strategy_Name(strategy));
    const std::string name = Create("signal", PendulumConfig(strategy)).name();
    Add(name, {PendulumTransitions(4, 0, 8)});
    absl::StatusOr<v1::PlanInputsResponse> now = client_->PlanInputs(name, {0.0, 0.0});
    ASSERT_TRUE(now.ok()) << now.status();
    absl::StatusOr<v1::PlanInputsResponse> later =
        client_->PlanInputs(name, {0.0, 0.0}, {now->inputs(0), now->inputs(1)});
    ASSERT_TRUE(later.ok()) << later.status();
    EXPECT_EQ(later->start_step(), 2);
    ASSERT_EQ(later->inputs_size(), 5);
    for (int k = 0; k + 2 < 5; ++k) EXPECT_EQ(later->inputs(k), now->inputs(k + 2)) << k;
    ASSERT_TRUE(client_->DeleteSession(name).ok());
  }
}

TEST_F(PlanAheadTest, BadPendingInputsAreInvalidArgumentNamingTheField) {
  const std::string name = Create("bad", PendulumConfig(v1::STRATEGY_REC)).name();
  Add(name, {PendulumTransitions(30, 0, 3)});
  struct Case {
    std::vector<double> pending;
    std::string field;
    std::string says;
  };
  for (const Case& c : {
           Case{std::vector<double>(6, 0.0), "pending_inputs",
                "0 to 5 steps"},  // horizon 5
           Case{{0.0, std::nan("")}, "pending_inputs[1]", "(step 1) must be finite"},
           Case{{0.0, 1e300}, "pending_inputs[1]", "within +-1e+30"},
       }) {
    SCOPED_TRACE(c.field);
    v1::PlanInputsRequest request;
    request.set_session(name);
    request.add_state(0.0);
    request.add_state(0.0);
    request.mutable_pending_inputs()->Add(c.pending.begin(), c.pending.end());
    grpc::ClientContext context;
    v1::PlanInputsResponse ignored;
    const grpc::Status status = stub_->PlanInputs(&context, request, &ignored);
    ASSERT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_THAT(status.error_message(), HasSubstr(c.says));
    const google::rpc::BadRequest bad = BadRequestOf(status);
    ASSERT_EQ(bad.field_violations_size(), 1);
    EXPECT_EQ(bad.field_violations(0).field(), c.field);
  }
  // Nothing was planned and the session still plans.
  EXPECT_FALSE(client_->GetSession(name)->has_last_plan());
  EXPECT_TRUE(client_->PlanInputs(name, {0.0, 0.0}, {0.5}).ok());
}

}  // namespace
}  // namespace excite::service
