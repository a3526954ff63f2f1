// The service over a real loopback server started in-process on port 0 with a
// temporary data directory, driven through the C++ client library (and a raw
// stub where a test needs messages the client would not send).

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <iostream>
#include <limits>
#include <memory>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/ascii.h"
#include "client/excite_client.h"
#include "gmock/gmock.h"
#include "google/rpc/error_details.pb.h"
#include "google/rpc/status.pb.h"
#include "grpcpp/create_channel.h"
#include "grpcpp/security/credentials.h"
#include "gtest/gtest.h"
#include "server/plan/plan_slots.h"
#include "server/service/config_text.h"
#include "server/service/config_validation.h"
#include "server/service/excite_server.h"
#include "server/session/machine_limits.h"
#include "server/store/sqlite_store.h"
#include "tests/service/pendulum_data.h"
#include "tests/service/service_fixture.h"
#include "tests/support/temp_dir.h"

namespace excite::service {
namespace {

using ::excite::testing::BadRequestOf;
using ::excite::testing::ExpectSameHyperparameters;
using ::excite::testing::ExpectStatus;
using ::excite::testing::PendulumConfig;
using ::excite::testing::PendulumStep;
using ::excite::testing::PendulumTransitions;
using ::testing::HasSubstr;
using ServiceTest = ::excite::testing::ServiceTest;

TEST_F(ServiceTest, CreateGetListDelete) {
  const v1::Session created = Create("pend-a");
  EXPECT_EQ(created.name(), "sessions/pend-a");
  EXPECT_EQ(created.sample_count(), 0);
  EXPECT_EQ(created.last_sequence(), -1);
  EXPECT_EQ(created.model_version(), 0);
  EXPECT_EQ(created.outputs_size(), 0);
  EXPECT_EQ(created.config().planner().tolerance(), 1e-4);  // defaults filled

  absl::StatusOr<v1::Session> generated = client_->CreateSession(PendulumConfig(), "");
  ASSERT_TRUE(generated.ok()) << generated.status();
  EXPECT_THAT(generated->name(), ::testing::MatchesRegex("sessions/[a-z0-9-]{1,63}"));
  for (const char* id : {"pend-d", "pend-c", "pend-b"}) Create(id);

  absl::StatusOr<v1::Session> got = client_->GetSession("sessions/pend-a");
  ASSERT_TRUE(got.ok()) << got.status();
  EXPECT_EQ(got->config().SerializeAsString(), created.config().SerializeAsString());

  // Paging in id order, 2 at a time: 5 sessions -> 3 pages.
  std::vector<std::string> names;
  std::string token;
  int pages = 0;
  do {
    absl::StatusOr<v1::ListSessionsResponse> page = client_->ListSessions(2, token);
    ASSERT_TRUE(page.ok()) << page.status();
    EXPECT_LE(page->sessions_size(), 2);
    for (const v1::Session& s : page->sessions()) names.push_back(s.name());
    token = page->next_page_token();
    ++pages;
  } while (!token.empty() && pages < 10);
  EXPECT_EQ(pages, 3);
  ASSERT_EQ(names.size(), 5u);
  EXPECT_TRUE(std::is_sorted(names.begin(), names.end()));
  EXPECT_EQ(std::set<std::string>(names.begin(), names.end()).size(), 5u);

  absl::StatusOr<v1::ListSessionsResponse> all = client_->ListSessions(0, "");
  ASSERT_TRUE(all.ok());
  EXPECT_EQ(all->sessions_size(), 5);
  EXPECT_TRUE(all->next_page_token().empty());

  ExpectStatus(client_->ListSessions(2, "not-a-token!").status(),
               absl::StatusCode::kInvalidArgument, "page_token");
  ExpectStatus(client_->ListSessions(-1, "").status(), absl::StatusCode::kInvalidArgument,
               "page_size");

  ASSERT_TRUE(client_->DeleteSession("sessions/pend-a").ok());
  ExpectStatus(client_->GetSession("sessions/pend-a").status(),
               absl::StatusCode::kNotFound, "session sessions/pend-a not found");
  ExpectStatus(client_->DeleteSession("sessions/pend-a"), absl::StatusCode::kNotFound,
               "not found");
  EXPECT_EQ(client_->ListSessions(0, "")->sessions_size(), 4);
  // The id is free again and the new session starts empty.
  EXPECT_EQ(Create("pend-a").sample_count(), 0);
}

TEST_F(ServiceTest, StreamDataThenPredict) {
  const std::string name = Create("pend").name();
  ExpectStatus(client_
                   ->Predict([&] {
                     v1::PredictRequest r;
                     r.set_session(name);
                     for (double v : {0.0, 0.0, 0.0}) r.add_inputs(v);
                     return r;
                   }())
                   .status(),
               absl::StatusCode::kFailedPrecondition,
               "session sessions/pend has 0 samples; at least 2 are needed");

  // 80 transitions in 4 messages of one stream.
  const std::vector<v1::Transition> data = PendulumTransitions(80, 0, 1);
  std::vector<std::vector<v1::Transition>> batches(4);
  for (size_t i = 0; i < data.size(); ++i) batches[i / 20].push_back(data[i]);
  const v1::AddDataResponse added = Add(name, batches);
  EXPECT_EQ(added.stored(), 80);
  EXPECT_EQ(added.duplicates(), 0);
  EXPECT_EQ(added.sample_count(), 80);
  EXPECT_EQ(added.model_version(), 4);  // one per message that stored something
  EXPECT_EQ(client_->GetSession(name)->outputs_size(), 0);  // not fitted yet

  // Predict at random test points against the true pendulum.
  const std::vector<v1::Transition> test = PendulumTransitions(30, 0, 99);
  v1::PredictRequest request;
  request.set_session(name);
  for (const v1::Transition& t : test) {
    request.add_inputs(t.state(0));
    request.add_inputs(t.state(1));
    request.add_inputs(t.input(0));
  }
  absl::StatusOr<v1::PredictResponse> predicted = client_->Predict(request);
  ASSERT_TRUE(predicted.ok()) << predicted.status();
  ASSERT_EQ(predicted->mean_size(), 60);
  ASSERT_EQ(predicted->variance_size(), 60);
  EXPECT_EQ(predicted->model_version(), 5);  // the lazy refit counts
  double se = 0.0, se_still = 0.0;
  for (int i = 0; i < 30; ++i) {
    for (int j = 0; j < 2; ++j) {
      const double truth = test[i].next_state(j);
      se += std::pow(predicted->mean(2 * i + j) - truth, 2);
      se_still += std::pow(test[i].state(j) - truth, 2);
      EXPECT_GE(predicted->variance(2 * i + j), 0.0);
    }
  }
  const double rmse = std::sqrt(se / 60), rmse_still = std::sqrt(se_still / 60);
  std::cout << "pendulum, 80 samples: GP RMSE " << rmse << " vs 'state stays' "
            << rmse_still << "\n";
  EXPECT_LT(rmse, 0.5 * rmse_still);

  request.set_include_noise(true);
  absl::StatusOr<v1::PredictResponse> noisy = client_->Predict(request);
  ASSERT_TRUE(noisy.ok());
  for (int k = 0; k < 60; ++k) EXPECT_GT(noisy->variance(k), predicted->variance(k));
  EXPECT_EQ(noisy->mean(0), predicted->mean(0));

  // Once fitted, GetSession reports the model per output dimension.
  absl::StatusOr<v1::Session> session = client_->GetSession(name);
  ASSERT_TRUE(session.ok());
  ASSERT_EQ(session->outputs_size(), 2);
  for (const v1::OutputModel& output : session->outputs()) {
    EXPECT_EQ(output.hyperparameters().lengthscales_size(), 3);
    EXPECT_GT(output.hyperparameters().signal_variance(), 0.0);
    EXPECT_GT(output.hyperparameters().noise_variance(), 0.0);
    EXPECT_TRUE(std::isfinite(output.log_marginal_likelihood()));
  }
  EXPECT_EQ(session->sample_count(), 80);
  EXPECT_EQ(session->last_sequence(), 79);
  EXPECT_EQ(session->model_version(), 5);
}

// Plans from the origin for each strategy: shape, bounds, apply_count.
TEST_F(ServiceTest, PlanInputsPerStrategy) {
  struct Case {
    v1::Strategy strategy;
    int horizon;
    int apply_count;
  };
  for (const Case& c : {Case{v1::STRATEGY_REC, 5, 1}, Case{v1::STRATEGY_PA, 5, 5},
                        Case{v1::STRATEGY_GREEDY, 1, 1}, Case{v1::STRATEGY_MI, 5, 1},
                        Case{v1::STRATEGY_ROI, 5, 1}, Case{v1::STRATEGY_OPTIMISTIC, 5, 1},
                        Case{v1::STRATEGY_AUTO, 5, 1}}) {
    SCOPED_TRACE(v1::Strategy_Name(c.strategy));
    const std::string id = absl::AsciiStrToLower(v1::Strategy_Name(c.strategy));
    std::string session_id = id;
    std::replace(session_id.begin(), session_id.end(), '_', '-');
    const std::string name = Create(session_id, PendulumConfig(c.strategy)).name();
    Add(name, {PendulumTransitions(30, 0, 3)});
    EXPECT_FALSE(client_->GetSession(name)->has_last_plan());
    absl::StatusOr<v1::PlanInputsResponse> plan = client_->PlanInputs(name, {0.1, -0.2});
    ASSERT_TRUE(plan.ok()) << plan.status();
    // The session reports it (the live view draws it) until the next plan.
    EXPECT_EQ(client_->GetSession(name)->last_plan().SerializeAsString(),
              plan->SerializeAsString());
    EXPECT_EQ(plan->horizon(), c.horizon);
    EXPECT_EQ(plan->apply_count(), c.apply_count);
    if (c.strategy == v1::STRATEGY_AUTO) {
      const absl::StatusOr<v1::Session> session = client_->GetSession(name);
      ASSERT_TRUE(session.ok()) << session.status();
      const auto& members = session->config().auto_().members();
      EXPECT_NE(std::find(members.begin(), members.end(), plan->planned_by()),
                members.end())
          << v1::Strategy_Name(plan->planned_by());
    } else {
      EXPECT_EQ(plan->planned_by(), c.strategy);
    }
    ASSERT_EQ(plan->inputs_size(), c.horizon);
    ASSERT_EQ(plan->predicted_states_size(), 2 * c.horizon);
    ASSERT_EQ(plan->predicted_variances_size(), 2 * c.horizon);
    for (double u : plan->inputs()) {
      EXPECT_GE(u, -3.0 - 1e-9);
      EXPECT_LE(u, 3.0 + 1e-9);
    }
    EXPECT_NEAR(plan->predicted_states(0), 0.1, 1e-9);
    EXPECT_NEAR(plan->predicted_states(1), -0.2, 1e-9);
    for (double v : plan->predicted_variances()) EXPECT_GE(v, 0.0);
    EXPECT_NE(plan->solver_status(), v1::SOLVER_STATUS_UNSPECIFIED);
    EXPECT_TRUE(std::isfinite(plan->objective()));
    EXPECT_GE(plan->iterations(), 0);
    EXPECT_GT(plan->wall_time_ms(), 0.0);
    EXPECT_EQ(plan->model_version(), 2);  // one AddData + one refit
    std::cout << v1::Strategy_Name(c.strategy) << ": "
              << v1::SolverStatus_Name(plan->solver_status()) << " in "
              << plan->wall_time_ms() << " ms, " << plan->iterations() << " iterations\n";
  }
}

// prbs, chirp and random need neither data nor a fitted model: PlanInputs works
// at 0 samples, returns `horizon` inputs to apply and no predictions, and does
// not refit; the signal continues with the samples the session holds, also
// across a server restart.
TEST_F(ServiceTest, ModelFreeStrategiesPlanWithoutData) {
  for (v1::Strategy strategy :
       {v1::STRATEGY_PRBS, v1::STRATEGY_CHIRP, v1::STRATEGY_RANDOM}) {
    SCOPED_TRACE(v1::Strategy_Name(strategy));
    std::string id = absl::AsciiStrToLower(v1::Strategy_Name(strategy));
    std::replace(id.begin(), id.end(), '_', '-');
    const std::string name = Create(id, PendulumConfig(strategy)).name();
    absl::StatusOr<v1::PlanInputsResponse> plan = client_->PlanInputs(name, {0.0, 0.0});
    ASSERT_TRUE(plan.ok()) << plan.status();
    EXPECT_EQ(plan->horizon(), 5);
    EXPECT_EQ(plan->apply_count(), 5);
    ASSERT_EQ(plan->inputs_size(), 5);
    EXPECT_EQ(plan->predicted_states_size(), 0);
    EXPECT_EQ(plan->predicted_variances_size(), 0);
    EXPECT_EQ(plan->objective(), 0.0);
    EXPECT_EQ(plan->solver_status(), v1::SOLVER_STATUS_CONVERGED);
    EXPECT_EQ(plan->model_version(), 0);
    for (double u : plan->inputs()) {
      EXPECT_GE(u, -3.0);
      EXPECT_LE(u, 3.0);
      if (strategy == v1::STRATEGY_PRBS) {
        EXPECT_TRUE(u == -3.0 || u == 3.0) << u;
      }
    }
    // No refit happened, and Predict still needs data.
    EXPECT_EQ(client_->GetSession(name)->outputs_size(), 0);
    v1::PredictRequest predict;
    predict.set_session(name);
    for (double v : {0.0, 0.0, 0.0}) predict.add_inputs(v);
    EXPECT_EQ(client_->Predict(predict).status().code(),
              absl::StatusCode::kFailedPrecondition);
  }

  // Continuation: 5 inputs at 0 samples, then 5 at 5 samples, equal the first 10
  // inputs of a horizon-10 session with the same seed; after a restart the
  // session (still 5 samples) gives the same second chunk again.
  const std::string a = Create("prbs-a", PendulumConfig(v1::STRATEGY_PRBS)).name();
  v1::SessionConfig long_config = PendulumConfig(v1::STRATEGY_PRBS);
  long_config.set_horizon(10);
  const std::string b = Create("prbs-b", long_config).name();
  absl::StatusOr<v1::PlanInputsResponse> first = client_->PlanInputs(a, {0.0, 0.0});
  ASSERT_TRUE(first.ok()) << first.status();
  Add(a, {PendulumTransitions(5, 0, 8)});
  absl::StatusOr<v1::PlanInputsResponse> second = client_->PlanInputs(a, {0.0, 0.0});
  ASSERT_TRUE(second.ok()) << second.status();
  absl::StatusOr<v1::PlanInputsResponse> whole = client_->PlanInputs(b, {0.0, 0.0});
  ASSERT_TRUE(whole.ok()) << whole.status();
  ASSERT_EQ(whole->inputs_size(), 10);
  for (int k = 0; k < 5; ++k) {
    EXPECT_EQ(first->inputs(k), whole->inputs(k)) << k;
    EXPECT_EQ(second->inputs(k), whole->inputs(5 + k)) << k;
  }
  StopServer();
  StartServer();
  absl::StatusOr<v1::PlanInputsResponse> restarted = client_->PlanInputs(a, {0.0, 0.0});
  ASSERT_TRUE(restarted.ok()) << restarted.status();
  for (int k = 0; k < 5; ++k) EXPECT_EQ(restarted->inputs(k), second->inputs(k)) << k;
}

TEST_F(ServiceTest, SepNeedsStateBoundsAndPlansOverTheWire) {
  v1::SessionConfig no_bounds = PendulumConfig(v1::STRATEGY_SEP);
  no_bounds.clear_state_bounds();
  ExpectStatus(client_->CreateSession(no_bounds, "sep-unbounded").status(),
               absl::StatusCode::kInvalidArgument, "config.state_bounds:");

  const std::string name = Create("sep", PendulumConfig(v1::STRATEGY_SEP)).name();
  ExpectStatus(client_->PlanInputs(name, {0.0, 0.0}).status(),
               absl::StatusCode::kFailedPrecondition, "at least 2 are needed");
  Add(name, {PendulumTransitions(30, 0, 3)});
  absl::StatusOr<v1::PlanInputsResponse> plan = client_->PlanInputs(name, {0.1, -0.2});
  ASSERT_TRUE(plan.ok()) << plan.status();
  const int h = plan->horizon();
  EXPECT_GE(h, 1);
  EXPECT_LE(h, 6);  // at most M = 5 steering inputs, then u*
  EXPECT_EQ(plan->apply_count(), h);
  ASSERT_EQ(plan->inputs_size(), h);
  ASSERT_EQ(plan->predicted_states_size(), 2 * h);
  ASSERT_EQ(plan->predicted_variances_size(), 2 * h);
  EXPECT_NEAR(plan->predicted_states(0), 0.1, 1e-9);
  EXPECT_NEAR(plan->predicted_states(1), -0.2, 1e-9);
  for (double u : plan->inputs()) {
    EXPECT_GE(u, -3.0);
    EXPECT_LE(u, 3.0);
  }
  EXPECT_TRUE(std::isfinite(plan->objective()));
  EXPECT_EQ(plan->model_version(), 2);  // one AddData + one refit
}

TEST_F(ServiceTest, TinyTimeBudgetGivesTimeLimitOrDeadlineExceeded) {
  v1::SessionConfig config = PendulumConfig();
  config.set_horizon(30);
  config.mutable_planner()->set_time_budget_s(1e-3);  // the least allowed
  const std::string name = Create("tiny-budget", config).name();
  Add(name, {PendulumTransitions(30, 0, 4)});
  absl::StatusOr<v1::PlanInputsResponse> plan = client_->PlanInputs(name, {0.0, 0.0});
  if (plan.ok()) {
    EXPECT_EQ(plan->solver_status(), v1::SOLVER_STATUS_TIME_LIMIT);
  } else {
    EXPECT_EQ(plan.status().code(), absl::StatusCode::kDeadlineExceeded) << plan.status();
  }
}

TEST_F(ServiceTest, RestartKeepsExactlyTheAcknowledgedSamples) {
  const std::string name = Create("durable").name();
  const std::vector<v1::Transition> data = PendulumTransitions(30, 0, 5);
  const std::vector<v1::Transition> first(data.begin(), data.begin() + 20);
  const std::vector<v1::Transition> second(data.begin() + 20, data.end());
  Add(name, {first});
  // A retry of the first batch overlapping new data: stored once.
  std::vector<v1::Transition> retry(data.begin() + 10, data.end());
  v1::AddDataResponse r = Add(name, {retry});
  EXPECT_EQ(r.stored(), 10);
  EXPECT_EQ(r.duplicates(), 10);
  EXPECT_EQ(r.sample_count(), 30);

  // A stream whose second message is invalid: the first one is acknowledged
  // (durable), the second not.
  v1::AddDataRequest ok_message;
  ok_message.set_session(name);
  for (const v1::Transition& t : PendulumTransitions(5, 100, 6)) {
    *ok_message.add_transitions() = t;
  }
  v1::AddDataRequest bad_message = ok_message;
  for (v1::Transition& t : *bad_message.mutable_transitions())
    t.set_sequence(t.sequence() + 5);
  bad_message.mutable_transitions(3)->set_state(1, std::nan(""));
  v1::AddDataResponse ignored;
  grpc::Status status = RawAddData({ok_message, bad_message}, &ignored);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(status.error_message(), HasSubstr("transitions[3].state[1]"));

  // Fit once so that hyperparameters are saved.
  v1::PredictRequest predict;
  predict.set_session(name);
  for (double v : {0.5, 0.5, 0.5}) predict.add_inputs(v);
  absl::StatusOr<v1::PredictResponse> before = client_->Predict(predict);
  ASSERT_TRUE(before.ok()) << before.status();
  const v1::Session before_restart = *client_->GetSession(name);
  EXPECT_EQ(before_restart.sample_count(), 35);
  EXPECT_EQ(before_restart.last_sequence(), 104);

  StopServer();
  StartServer();

  absl::StatusOr<v1::Session> after = client_->GetSession(name);
  ASSERT_TRUE(after.ok()) << after.status();
  EXPECT_EQ(after->sample_count(), 35);
  EXPECT_EQ(after->last_sequence(), 104);
  EXPECT_EQ(after->config().SerializeAsString(),
            before_restart.config().SerializeAsString());
  EXPECT_GE(after->model_version(), before_restart.model_version());
  // Retrying everything after the restart stores nothing twice.
  v1::AddDataResponse again = Add(name, {first, second});
  EXPECT_EQ(again.stored(), 0);
  EXPECT_EQ(again.duplicates(), 30);
  EXPECT_EQ(again.sample_count(), 35);
  // The model is rebuilt from the same data: the same prediction (up to the fit).
  absl::StatusOr<v1::PredictResponse> restored = client_->Predict(predict);
  ASSERT_TRUE(restored.ok()) << restored.status();
  EXPECT_NEAR(restored->mean(0), before->mean(0), 1e-3);
  EXPECT_NEAR(restored->mean(1), before->mean(1), 1e-3);
}

// StreamData acknowledges each message once it is stored, so a plant knows
// exactly what to resend: after an invalid message, a cancelled stream or a
// restart, the session holds the acknowledged messages (and a resend of the rest
// stores each transition once).
TEST_F(ServiceTest, StreamDataAcknowledgesEachStoredMessage) {
  const std::string name = Create("acked").name();
  const std::vector<v1::Transition> data = PendulumTransitions(60, 0, 8);
  auto batch = [&data](int k) {  // transitions 10k .. 10k + 9
    return std::vector<v1::Transition>(data.begin() + 10 * k, data.begin() + 10 * k + 10);
  };

  std::unique_ptr<client::DataStream> stream = client_->OpenDataStream(name);
  for (int k = 0; k < 3; ++k) {
    absl::StatusOr<v1::AddDataAck> ack = stream->Send(batch(k));
    ASSERT_TRUE(ack.ok()) << ack.status();
    EXPECT_EQ(ack->message_index(), k);
    EXPECT_EQ(ack->stored(), 10);
    EXPECT_EQ(ack->duplicates(), 0);
    EXPECT_EQ(ack->sample_count(), 10 * (k + 1));
    EXPECT_EQ(ack->model_version(), k + 1);
    // Acknowledged means stored: another client sees it at once.
    EXPECT_EQ(client_->GetSession(name)->sample_count(), 10 * (k + 1));
  }
  // A retried message: acknowledged, stored nothing new.
  absl::StatusOr<v1::AddDataAck> retried = stream->Send(batch(1));
  ASSERT_TRUE(retried.ok()) << retried.status();
  EXPECT_EQ(retried->message_index(), 3);
  EXPECT_EQ(retried->stored(), 0);
  EXPECT_EQ(retried->duplicates(), 10);
  // An invalid message ends the stream with its error; nothing of it is stored.
  std::vector<v1::Transition> bad = batch(3);
  bad[4].set_state(0, std::nan(""));
  absl::StatusOr<v1::AddDataAck> refused = stream->Send(bad);
  ExpectStatus(refused.status(), absl::StatusCode::kInvalidArgument,
               "message 4: transitions[4].state[0]");
  EXPECT_EQ(stream->Send(batch(3)).status().code(),
            absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(client_->GetSession(name)->sample_count(), 30);

  // A stream dropped by its client after one acknowledgement: that message is
  // stored and survives a restart.
  stream = client_->OpenDataStream(name);
  ASSERT_TRUE(stream->Send(batch(3)).ok());
  stream.reset();  // cancels the call
  StopServer();
  StartServer();
  EXPECT_EQ(client_->GetSession(name)->sample_count(), 40);

  // Resending everything on a new stream stores only what is new.
  stream = client_->OpenDataStream(name);
  int64_t stored = 0, duplicates = 0;
  for (int k = 0; k < 6; ++k) {
    absl::StatusOr<v1::AddDataAck> ack = stream->Send(batch(k));
    ASSERT_TRUE(ack.ok()) << ack.status();
    stored += ack->stored();
    duplicates += ack->duplicates();
  }
  EXPECT_TRUE(stream->Close().ok());
  EXPECT_EQ(stored, 20);
  EXPECT_EQ(duplicates, 40);
  EXPECT_EQ(client_->GetSession(name)->sample_count(), 60);
  EXPECT_EQ(client_->GetSession(name)->last_sequence(), 59);

  // The first message must name a session that exists.
  stream = client_->OpenDataStream("sessions/nope");
  ExpectStatus(stream->Send(batch(0)).status(), absl::StatusCode::kNotFound,
               "sessions/nope");
}

TEST_F(ServiceTest, RefitNeverKeepsSavedHyperparametersAcrossRestart) {
  v1::SessionConfig config = PendulumConfig();
  config.mutable_refit()->set_never(true);
  const std::string name = Create("frozen", config).name();
  Add(name, {PendulumTransitions(25, 0, 11)});
  v1::PredictRequest predict;
  predict.set_session(name);
  for (double v : {0.3, -0.4, 1.0}) predict.add_inputs(v);
  ASSERT_TRUE(client_->Predict(predict).ok());
  // More data: no refit (model_version counts the add only).
  const v1::AddDataResponse more = Add(name, {PendulumTransitions(5, 25, 12)});
  absl::StatusOr<v1::PredictResponse> before = client_->Predict(predict);
  ASSERT_TRUE(before.ok()) << before.status();
  EXPECT_EQ(before->model_version(), more.model_version());
  const v1::Session fitted = *client_->GetSession(name);
  ASSERT_EQ(fitted.outputs_size(), 2);

  StopServer();
  StartServer();
  EXPECT_EQ(client_->GetSession(name)->outputs_size(), 0);  // fitted lazily
  absl::StatusOr<v1::PredictResponse> after = client_->Predict(predict);
  ASSERT_TRUE(after.ok()) << after.status();
  const v1::Session restored = *client_->GetSession(name);
  ASSERT_EQ(restored.outputs_size(), 2);
  ExpectSameHyperparameters(restored, fitted);
  // The prior mean is the mean of all 30 targets before and after.
  EXPECT_NEAR(after->mean(0), before->mean(0), 1e-9);
  EXPECT_NEAR(after->mean(1), before->mean(1), 1e-9);
}

// In every refit policy, a session predicts the same (to rounding) before and
// after a restart, and after an export and import: the prior mean follows the
// data, and a saved fit that is still current is used as it is (no refit).
TEST_F(ServiceTest, PredictionsSurviveRestartAndImportInEveryRefitPolicy) {
  struct Policy {
    const char* id;
    int every_samples;
    double growth;
    bool never;
    bool fixed;
    int sparse_above;  // 0: the default (1000, never reached here)
  };
  // The sparse ones: from the first fit (20), and crossing 26 between two fits.
  const Policy policies[] = {{"every-1", 1, 0.0, false, false, 0},
                             {"every-5", 5, 0.0, false, false, 0},
                             {"growth-20", 1, 0.2, false, false, 0},
                             {"never", 0, 0.0, true, false, 0},
                             {"fixed", 0, 0.0, false, true, 0},
                             {"sparse-every-1", 1, 0.0, false, false, 20},
                             {"sparse-fixed", 0, 0.0, false, true, 20},
                             {"sparse-crossing", 1, 0.2, false, false, 26}};
  v1::PredictRequest predict;
  for (double v : {0.3, -0.4, 1.0, -2.0, 5.0, -1.5}) predict.add_inputs(v);
  std::vector<v1::PredictResponse> before;
  for (const Policy& p : policies) {
    v1::SessionConfig config = PendulumConfig();
    if (p.fixed) {
      config.mutable_noise()->set_fit(false);
      config.mutable_kernel()->clear_fit();  // unset with `fixed`: not fitted
      for (int j = 0; j < 2; ++j) {
        v1::Hyperparameters* h = config.mutable_kernel()->add_fixed();
        h->set_signal_variance(1.5 + j);
        for (double l : {1.0, 4.0, 2.0}) h->add_lengthscales(l);
        h->set_noise_variance(1e-4);
      }
    }
    config.mutable_refit()->set_every_samples(p.every_samples);
    config.mutable_refit()->set_growth(p.growth);
    config.mutable_refit()->set_never(p.never);
    if (p.sparse_above > 0) config.mutable_sparse()->set_above_samples(p.sparse_above);
    const std::string name = Create(p.id, config).name();
    EXPECT_EQ(client_->GetSession(name)->config().kernel().fit(), !p.fixed);
    Add(name, {PendulumTransitions(25, 0, 31)});
    predict.set_session(name);
    ASSERT_TRUE(client_->Predict(predict).ok());
    // 3 more: every-1 refits at the next Predict, every-5 and growth-20 (20 % of
    // 25: 5) do not, the others never do; each moves the prior mean.
    Add(name, {PendulumTransitions(3, 25, 32)});
    absl::StatusOr<v1::PredictResponse> response = client_->Predict(predict);
    ASSERT_TRUE(response.ok()) << response.status();
    before.push_back(*response);
    absl::StatusOr<v1::Session> session = client_->GetSession(name);
    ASSERT_TRUE(session.ok()) << session.status();
    for (const v1::OutputModel& output : session->outputs()) {
      if (p.sparse_above > 0) {
        EXPECT_GT(output.inducing_points(), 0) << name;
      } else {
        EXPECT_EQ(output.inducing_points(), 0) << name;
      }
    }
  }
  auto expect_same = [&](const std::string& name, const v1::PredictResponse& expected) {
    predict.set_session(name);
    absl::StatusOr<v1::PredictResponse> got = client_->Predict(predict);
    ASSERT_TRUE(got.ok()) << got.status();
    ASSERT_EQ(got->mean_size(), expected.mean_size());
    for (int i = 0; i < expected.mean_size(); ++i) {
      EXPECT_NEAR(got->mean(i), expected.mean(i), 1e-9) << name << " mean " << i;
      EXPECT_NEAR(got->variance(i), expected.variance(i),
                  1e-9 * std::abs(expected.variance(i)) + 1e-15)
          << name << " variance " << i;
    }
  };
  StopServer();
  StartServer();
  for (size_t k = 0; k < before.size(); ++k) {
    expect_same(absl::StrCat("sessions/", policies[k].id), before[k]);
  }
  for (size_t k = 0; k < before.size(); ++k) {
    absl::StatusOr<v1::SessionArchive> archive =
        client_->ExportSession(absl::StrCat("sessions/", policies[k].id));
    ASSERT_TRUE(archive.ok()) << archive.status();
    const std::string id = absl::StrCat("imported-", policies[k].id);
    ASSERT_TRUE(client_->ImportSession(*archive, id).ok());
    expect_same(absl::StrCat("sessions/", id), before[k]);
  }
}

// refit.growth spaces refits: with 0.2, a fit on 25 samples is next due 5 samples
// later (a refit is a model version of its own; each stored sample is one too).
TEST_F(ServiceTest, RefitGrowthWaitsForAFractionOfTheFittedSamples) {
  v1::SessionConfig config = PendulumConfig();
  config.mutable_refit()->set_growth(0.2);
  const std::string name = Create("growth", config).name();
  Add(name, {PendulumTransitions(25, 0, 41)});
  v1::PredictRequest predict;
  predict.set_session(name);
  for (double v : {0.3, -0.4, 1.0}) predict.add_inputs(v);
  ASSERT_TRUE(client_->Predict(predict).ok());  // the first fit
  const int64_t after_four = Add(name, {PendulumTransitions(4, 25, 42)}).model_version();
  absl::StatusOr<v1::PredictResponse> response = client_->Predict(predict);
  ASSERT_TRUE(response.ok()) << response.status();
  EXPECT_EQ(response->model_version(), after_four);  // 4 < 5: no refit
  const int64_t after_five = Add(name, {PendulumTransitions(1, 29, 43)}).model_version();
  response = client_->Predict(predict);
  ASSERT_TRUE(response.ok()) << response.status();
  EXPECT_EQ(response->model_version(), after_five + 1);  // refitted
}

// A refitting session comes back from a restart with its last fitted
// hyperparameters (reported before any new refit, and the warm start of the
// first one).
TEST_F(ServiceTest, RestartRestoresSavedHyperparameters) {
  const std::string name = Create("warm").name();
  Add(name, {PendulumTransitions(25, 0, 21)});
  v1::PredictRequest predict;
  predict.set_session(name);
  for (double v : {0.3, -0.4, 1.0}) predict.add_inputs(v);
  ASSERT_TRUE(client_->Predict(predict).ok());
  const v1::Session fitted = *client_->GetSession(name);
  ASSERT_EQ(fitted.outputs_size(), 2);

  StopServer();
  StartServer();
  const v1::Session restored = *client_->GetSession(name);
  ASSERT_EQ(restored.outputs_size(), 2);  // before any refit
  for (int i = 0; i < 2; ++i) {
    EXPECT_EQ(restored.outputs(i).hyperparameters().SerializeAsString(),
              fitted.outputs(i).hyperparameters().SerializeAsString());
  }
  // No sample since that fit: the next Predict rebuilds with them (no refit).
  ASSERT_TRUE(client_->Predict(predict).ok());
  const v1::Session rebuilt = *client_->GetSession(name);
  ExpectSameHyperparameters(rebuilt, fitted);
  // The next sample makes a refit due, which starts there: with nearly the same
  // data it stays close.
  Add(name, {PendulumTransitions(1, 25, 22)});
  ASSERT_TRUE(client_->Predict(predict).ok());
  const v1::Session refitted = *client_->GetSession(name);
  ASSERT_EQ(refitted.outputs_size(), 2);
  for (int i = 0; i < 2; ++i) {
    const v1::Hyperparameters& a = fitted.outputs(i).hyperparameters();
    const v1::Hyperparameters& b = refitted.outputs(i).hyperparameters();
    EXPECT_NEAR(std::log(b.signal_variance()), std::log(a.signal_variance()), 0.2);
  }
}

// Restart time of a server holding 100 sessions x 1000 samples (a timing
// print, not an assertion). GPs are rebuilt at load (data copied in, no
// factorisation) and fitted lazily at first use.
TEST_F(ServiceTest, RestartTimeFor100SessionsOf1000Samples) {
  const std::string name = Create("seed").name();
  Add(name, {PendulumTransitions(25, 0, 3)});
  v1::PredictRequest predict;
  predict.set_session(name);
  for (double v : {0.3, -0.4, 1.0}) predict.add_inputs(v);
  ASSERT_TRUE(client_->Predict(predict).ok());
  v1::Session saved_outputs;
  *saved_outputs.mutable_outputs() = client_->GetSession(name)->outputs();
  StopServer();
  {
    absl::StatusOr<std::unique_ptr<store::SqliteStore>> store =
        store::SqliteStore::Open(tmp_.path() + "/data");
    ASSERT_TRUE(store.ok()) << store.status();
    absl::StatusOr<v1::SessionConfig> config =
        ValidatedSessionConfig(PendulumConfig(), "config");
    ASSERT_TRUE(config.ok()) << config.status();
    const std::vector<v1::Transition> data = PendulumTransitions(1000, 0, 4);
    std::vector<store::SampleRecord> samples;
    for (const v1::Transition& t : data) {
      store::SampleRecord r;
      r.sequence = t.sequence();
      r.state.assign(t.state().begin(), t.state().end());
      r.input.assign(t.input().begin(), t.input().end());
      r.next_state.assign(t.next_state().begin(), t.next_state().end());
      samples.push_back(std::move(r));
    }
    for (int i = 0; i < 100; ++i) {
      store::SessionRecord record;
      record.id = "bulk-" + std::to_string(i);
      record.config = config->SerializeAsString();
      ASSERT_TRUE((*store)->CreateSession(record).ok());
      ASSERT_TRUE((*store)->InsertSamples(record.id, /*fence=*/0, samples).ok());
      ASSERT_TRUE((*store)
                      ->SaveModelState(record.id, /*fence=*/0,
                                       saved_outputs.SerializeAsString(), 1)
                      .ok());
    }
  }
  const auto t0 = std::chrono::steady_clock::now();
  StartServer();
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::cout << "restart with 100 sessions x 1000 samples: " << seconds << " s\n";
  absl::StatusOr<v1::Session> bulk = client_->GetSession("sessions/bulk-42");
  ASSERT_TRUE(bulk.ok()) << bulk.status();
  EXPECT_EQ(bulk->sample_count(), 1000);
  EXPECT_EQ(bulk->outputs_size(), 2);
}

TEST_F(ServiceTest, InvalidArgumentCarriesBadRequestFieldViolations) {
  // A config error.
  v1::CreateSessionRequest create;
  create.set_session_id("details");
  *create.mutable_config() = PendulumConfig();
  create.mutable_config()->mutable_input_bounds(0)->set_lower(5);
  {
    grpc::ClientContext context;
    v1::Session ignored;
    const grpc::Status status = stub_->CreateSession(&context, create, &ignored);
    ASSERT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    const google::rpc::BadRequest bad = BadRequestOf(status);
    ASSERT_EQ(bad.field_violations_size(), 1);
    EXPECT_THAT(bad.field_violations(0).field(), HasSubstr("config.input_bounds[0]"));
    EXPECT_FALSE(bad.field_violations(0).description().empty());
    EXPECT_THAT(status.error_message(), HasSubstr(bad.field_violations(0).field()));
  }
  // Three problems at once: one violation each, all in the message; an unknown
  // enum value lists the valid ones.
  create.mutable_config()->mutable_noise()->set_variance(-1);
  create.mutable_config()->set_strategy(static_cast<v1::Strategy>(42));
  {
    grpc::ClientContext context;
    v1::Session ignored;
    const grpc::Status status = stub_->CreateSession(&context, create, &ignored);
    ASSERT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_THAT(status.error_message(), HasSubstr("3 problems: config.input_bounds[0]"));
    const google::rpc::BadRequest bad = BadRequestOf(status);
    ASSERT_EQ(bad.field_violations_size(), 3);
    EXPECT_EQ(bad.field_violations(0).field(), "config.input_bounds[0]");
    EXPECT_EQ(bad.field_violations(1).field(), "config.noise.variance");
    EXPECT_EQ(bad.field_violations(2).field(), "config.strategy");
    EXPECT_THAT(bad.field_violations(2).description(),
                HasSubstr("unknown value 42; valid: STRATEGY_REC, STRATEGY_PA"));
    EXPECT_THAT(bad.field_violations(1).description(), HasSubstr("got -1"));
  }
  // A request error in the second message of an AddData stream.
  const std::string name = Create("details-ok").name();
  v1::AddDataRequest good;
  good.set_session(name);
  for (const v1::Transition& t : PendulumTransitions(3, 0, 9))
    *good.add_transitions() = t;
  v1::AddDataRequest bad_message = good;
  for (v1::Transition& t : *bad_message.mutable_transitions()) {
    t.set_sequence(t.sequence() + 3);
  }
  bad_message.mutable_transitions(2)->set_next_state(1, std::nan(""));
  v1::AddDataResponse ignored;
  const grpc::Status status = RawAddData({good, bad_message}, &ignored);
  ASSERT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  const google::rpc::BadRequest bad = BadRequestOf(status);
  ASSERT_EQ(bad.field_violations_size(), 1);
  EXPECT_EQ(bad.field_violations(0).field(), "transitions[2].next_state[1]");
  EXPECT_THAT(bad.field_violations(0).description(), HasSubstr("must be finite"));
  // Errors that are not about a field carry no details.
  grpc::ClientContext context;
  v1::GetSessionRequest get;
  get.set_name("sessions/nope");
  v1::Session session;
  const grpc::Status not_found = stub_->GetSession(&context, get, &session);
  EXPECT_EQ(not_found.error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_TRUE(not_found.error_details().empty());
}

// Every configurable cap is RESOURCE_EXHAUSTED with a message naming it.
TEST(ServiceCapsTest, EachCapIsResourceExhausted) {
  excite::testing::TempDir tmp;
  ServerOptions options;
  options.listen = "127.0.0.1:0";
  options.data_dir = tmp.path() + "/data";
  options.max_message_mb = 1;
  options.limits.max_sessions = 2;
  options.limits.max_samples_per_session = 10;
  options.limits.max_predict_points = 3;
  options.limits.max_horizon = 5;
  absl::StatusOr<std::unique_ptr<ExciteServer>> server = ExciteServer::Start(options);
  ASSERT_TRUE(server.ok()) << server.status();
  auto client = client::ExciteClient::Connect((*server)->address());

  // Horizon: 5 passes, 6 does not (and nothing is stored).
  v1::SessionConfig config = PendulumConfig();
  config.set_horizon(6);
  ExpectStatus(client->CreateSession(config, "a").status(),
               absl::StatusCode::kResourceExhausted, "cap of 5 (--max_horizon)");
  config.set_horizon(5);
  ASSERT_TRUE(client->CreateSession(config, "a").ok());
  ASSERT_TRUE(client->CreateSession(config, "b").ok());
  // Sessions: 2.
  ExpectStatus(client->CreateSession(config, "c").status(),
               absl::StatusCode::kResourceExhausted, "2 sessions, its cap");
  // Samples per session: 10 (an add that would cross it stores nothing).
  ASSERT_TRUE(client->AddData("sessions/a", {PendulumTransitions(8, 0, 1)}).ok());
  ExpectStatus(client->AddData("sessions/a", {PendulumTransitions(3, 8, 2)}).status(),
               absl::StatusCode::kResourceExhausted, "cap of 10 per session");
  EXPECT_EQ(client->GetSession("sessions/a")->sample_count(), 8);
  // Points per Predict: 3.
  v1::PredictRequest predict;
  predict.set_session("sessions/a");
  for (int i = 0; i < 4 * 3; ++i) predict.add_inputs(0.1);
  ExpectStatus(client->Predict(predict).status(), absl::StatusCode::kResourceExhausted,
               "4 points exceed the cap of 3");
  predict.mutable_inputs()->Truncate(3 * 3);
  EXPECT_TRUE(client->Predict(predict).ok());
  // Message size: 1 MiB (gRPC's own check, before the service sees it).
  for (int i = 0; i < 200000; ++i) predict.add_inputs(0.1);
  const absl::Status too_big = client->Predict(predict).status();
  EXPECT_EQ(too_big.code(), absl::StatusCode::kResourceExhausted) << too_big;
  EXPECT_THAT(std::string(too_big.message()), HasSubstr("larger than max"));
}

// --planner_workers: out of range is INVALID_ARGUMENT naming it; in range, it is
// the number of plans the process runs at once; 0 is the cores it may use.
TEST(ServiceCapsTest, PlannerWorkersSetThePlansThatRunAtOnce) {
  excite::testing::TempDir tmp;
  ServerOptions options;
  options.listen = "127.0.0.1:0";
  options.data_dir = tmp.path() + "/data";
  for (const int bad : {-1, 1025}) {
    options.planner_workers = bad;
    ExpectStatus(ExciteServer::Start(options).status(),
                 absl::StatusCode::kInvalidArgument,
                 "planner_workers must be in [0, 1024]");
  }
  options.planner_workers = 3;
  {
    absl::StatusOr<std::unique_ptr<ExciteServer>> server = ExciteServer::Start(options);
    ASSERT_TRUE(server.ok()) << server.status();
    EXPECT_EQ(plan::ConcurrentPlans(), 3);
  }
  options.planner_workers = 0;
  {
    absl::StatusOr<std::unique_ptr<ExciteServer>> server = ExciteServer::Start(options);
    ASSERT_TRUE(server.ok()) << server.status();
    EXPECT_EQ(plan::ConcurrentPlans(), session::AvailableCores());
  }
  plan::SetConcurrentPlans(1);
}

// Sessions work in parallel; one session's calls are serialised. Four threads
// stream into and plan for their own sessions while a fifth lists and reads.
TEST_F(ServiceTest, ConcurrentSessions) {
  constexpr int kThreads = 4;
  std::vector<std::string> names;
  for (int i = 0; i < kThreads; ++i) {
    names.push_back(Create("par-" + std::to_string(i)).name());
  }
  std::vector<std::thread> threads;
  std::vector<int> failures(kThreads + 1, 0);
  for (int i = 0; i < kThreads; ++i) {
    threads.emplace_back([&, i]() {
      for (int step = 0; step < 4; ++step) {
        // Two writers per session: one from this thread, the same batch again
        // from a helper (duplicates must be detected whatever the order).
        const std::vector<v1::Transition> batch =
            PendulumTransitions(5, 5 * step, static_cast<uint32_t>(100 + i));
        std::thread twin([&]() {
          if (!client_->AddData(names[i], {batch}).ok()) ++failures[i];
        });
        if (!client_->AddData(names[i], {batch}).ok()) ++failures[i];
        twin.join();
        if (!client_->PlanInputs(names[i], {0.0, 0.0}).ok()) ++failures[i];
      }
    });
  }
  threads.emplace_back([&]() {
    for (int k = 0; k < 20; ++k) {
      absl::StatusOr<v1::ListSessionsResponse> list = client_->ListSessions(0, "");
      if (!list.ok() || list->sessions_size() != kThreads) ++failures[kThreads];
    }
  });
  for (std::thread& t : threads) t.join();
  for (int i = 0; i <= kThreads; ++i) EXPECT_EQ(failures[i], 0) << "thread " << i;
  for (const std::string& name : names) {
    EXPECT_EQ(client_->GetSession(name)->sample_count(), 20) << name;
  }
}

TEST_F(ServiceTest, DrainingRefusesNewRpcs) {
  server_->Shutdown(std::chrono::milliseconds(100));
  absl::Status status = client_->ListSessions(0, "").status();
  EXPECT_EQ(status.code(), absl::StatusCode::kUnavailable) << status;
}

TEST_F(ServiceTest, ErrorCodes) {
  const std::string name = Create("errors").name();
  // NOT_FOUND / malformed names.
  ExpectStatus(client_->GetSession("sessions/nope").status(), absl::StatusCode::kNotFound,
               "session sessions/nope not found");
  ExpectStatus(client_->GetSession("nope").status(), absl::StatusCode::kInvalidArgument,
               "name:");
  ExpectStatus(client_->GetSession("sessions/UPPER").status(),
               absl::StatusCode::kInvalidArgument, "name:");
  ExpectStatus(client_->PlanInputs("sessions/nope", {0, 0}).status(),
               absl::StatusCode::kNotFound, "not found");
  ExpectStatus(client_->AddData("sessions/nope", {PendulumTransitions(1, 0, 1)}).status(),
               absl::StatusCode::kNotFound, "not found");
  // ALREADY_EXISTS and bad configs / ids.
  ExpectStatus(client_->CreateSession(PendulumConfig(), "errors").status(),
               absl::StatusCode::kAlreadyExists, "already exists");
  v1::SessionConfig bad = PendulumConfig();
  bad.mutable_input_bounds(0)->set_lower(2);
  bad.mutable_input_bounds(0)->set_upper(1);
  ExpectStatus(client_->CreateSession(bad, "bad").status(),
               absl::StatusCode::kInvalidArgument,
               "config.input_bounds[0]: lower (2) must be < upper (1)");
  ExpectStatus(client_->CreateSession(PendulumConfig(), "Bad_Id").status(),
               absl::StatusCode::kInvalidArgument, "session_id");
  ExpectStatus(client_->CreateSession(PendulumConfig(), std::string(64, 'a')).status(),
               absl::StatusCode::kInvalidArgument, "session_id");
  // FAILED_PRECONDITION before data (also with 1 sample < min_samples = 2).
  ExpectStatus(client_->PlanInputs(name, {0, 0}).status(),
               absl::StatusCode::kFailedPrecondition, "at least 2 are needed");
  Add(name, {PendulumTransitions(1, 0, 1)});
  ExpectStatus(client_->PlanInputs(name, {0, 0}).status(),
               absl::StatusCode::kFailedPrecondition, "has 1 samples");

  // AddData validation: shapes, finiteness, sequence numbers.
  auto add_one = [&](const std::function<void(v1::Transition*)>& edit) {
    std::vector<v1::Transition> batch = PendulumTransitions(3, 10, 2);
    edit(&batch[1]);
    return client_->AddData(name, {batch}).status();
  };
  ExpectStatus(add_one([](v1::Transition* t) { t->add_state(1.0); }),
               absl::StatusCode::kInvalidArgument,
               "transitions[1].state: must have state_dim (2) numbers, got 3");
  ExpectStatus(add_one([](v1::Transition* t) { t->clear_input(); }),
               absl::StatusCode::kInvalidArgument, "transitions[1].input");
  ExpectStatus(add_one([](v1::Transition* t) { t->mutable_next_state()->RemoveLast(); }),
               absl::StatusCode::kInvalidArgument, "transitions[1].next_state");
  ExpectStatus(add_one([](v1::Transition* t) {
                 t->set_input(0, std::numeric_limits<double>::infinity());
               }),
               absl::StatusCode::kInvalidArgument,
               "transitions[1].input[0]: must be finite");
  ExpectStatus(add_one([](v1::Transition* t) { t->set_sequence(-1); }),
               absl::StatusCode::kInvalidArgument,
               "transitions[1].sequence: must be >= 0");
  ExpectStatus(add_one([](v1::Transition* t) { t->set_sequence(10); }),
               absl::StatusCode::kInvalidArgument, "appears twice in one message");
  EXPECT_EQ(client_->GetSession(name)->sample_count(), 1);  // nothing of those stored

  // Streams: the first message must name the session; later ones must agree.
  Create("other");
  v1::AddDataRequest unnamed;
  *unnamed.add_transitions() = PendulumTransitions(1, 50, 3)[0];
  v1::AddDataResponse response;
  grpc::Status status = RawAddData({unnamed}, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(status.error_message(), HasSubstr("session: required in the first"));
  v1::AddDataRequest named = unnamed;
  named.set_session(name);
  v1::AddDataRequest later_unnamed;  // allowed: later messages may omit the name
  *later_unnamed.add_transitions() = PendulumTransitions(1, 51, 3)[0];
  v1::AddDataRequest other = later_unnamed;
  other.set_session("sessions/other");
  other.mutable_transitions(0)->set_sequence(52);
  status = RawAddData({named, later_unnamed, other}, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(status.error_message(), HasSubstr("names sessions/other"));
  EXPECT_EQ(client_->GetSession(name)->sample_count(), 3);  // first two were stored
  EXPECT_EQ(client_->GetSession("sessions/other")->sample_count(), 0);
  status = RawAddData({}, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);

  // Predict validation.
  v1::PredictRequest predict;
  predict.set_session(name);
  ExpectStatus(client_->Predict(predict).status(), absl::StatusCode::kInvalidArgument,
               "inputs: must hold at least one point");
  for (double v : {0.0, 0.0, 0.0, 1.0}) predict.add_inputs(v);
  ExpectStatus(client_->Predict(predict).status(), absl::StatusCode::kInvalidArgument,
               "not a multiple of state_dim + input_dim (3)");
  predict.add_inputs(0.0);
  predict.add_inputs(std::nan(""));
  ExpectStatus(client_->Predict(predict).status(), absl::StatusCode::kInvalidArgument,
               "inputs[5]: (point 1) must be finite");
  predict.set_session("sessions/");
  ExpectStatus(client_->Predict(predict).status(), absl::StatusCode::kInvalidArgument,
               "session:");

  // PlanInputs validation.
  ExpectStatus(client_->PlanInputs(name, {0.0}).status(),
               absl::StatusCode::kInvalidArgument,
               "state: must have state_dim (2) numbers, got 1");
  ExpectStatus(client_->PlanInputs(name, {0.0, std::nan("")}).status(),
               absl::StatusCode::kInvalidArgument, "state[1]: must be finite");
  ExpectStatus(client_->PlanInputs("", {0.0, 0.0}).status(),
               absl::StatusCode::kInvalidArgument, "session: required");

  // Caps: RESOURCE_EXHAUSTED (this test server allows 500 samples per session).
  ExpectStatus(client_->AddData(name, {PendulumTransitions(600, 1000, 4)}).status(),
               absl::StatusCode::kResourceExhausted, "cap of 500");
}

TEST_F(ServiceTest, DeletedSessionRejectsLaterCallsAndItsDataIsGone) {
  const std::string name = Create("gone").name();
  Add(name, {PendulumTransitions(10, 0, 8)});
  ASSERT_TRUE(client_->DeleteSession(name).ok());
  Create("gone");
  StopServer();
  StartServer();
  absl::StatusOr<v1::Session> session = client_->GetSession(name);
  ASSERT_TRUE(session.ok());
  EXPECT_EQ(session->sample_count(), 0);  // the new session, not the old data
}

TEST_F(ServiceTest, AddDataLatency) {
  const std::string name = Create("latency").name();
  const std::vector<v1::Transition> data = PendulumTransitions(50, 0, 9);
  const auto start = std::chrono::steady_clock::now();
  for (int i = 0; i < 50; ++i) {
    ASSERT_TRUE(client_->AddData(name, {{data[i]}}).ok());
  }
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
          .count() /
      50;
  std::cout << "AddData of one transition (durable, one stream per call): " << ms
            << " ms mean over 50 calls\n";
  RecordProperty("add_data_ms", std::to_string(ms));
  EXPECT_EQ(client_->GetSession(name)->sample_count(), 50);
}

// GetSessionHistory: every plan, the one-step error of each batch as the model
// predicted it before the batch (checked against Predict called just before),
// and the mean std over the region, which fixed hyperparameters can only lower.
TEST_F(ServiceTest, SessionHistoryRecordsPlansBatchErrorsAndUncertainty) {
  const std::string name =
      Create("history", testing::PendulumFixedKernelConfig(
                            testing::PendulumHyperparameters(0.5, {1, 1, 1}),
                            testing::PendulumHyperparameters(4.0, {1, 1, 1})))
          .name();
  Add(name, {PendulumTransitions(30, 0, 3)});
  // The model is fitted at its first use: no batch was scored before.
  absl::StatusOr<v1::PlanInputsResponse> plan = client_->PlanInputs(name, {0.1, -0.2});
  ASSERT_TRUE(plan.ok()) << plan.status();
  absl::StatusOr<v1::SessionHistory> history = client_->GetSessionHistory(name);
  ASSERT_TRUE(history.ok()) << history.status();
  ASSERT_EQ(history->plans_size(), 1);
  EXPECT_EQ(history->plans(0).sample_count(), 30);
  EXPECT_EQ(history->plans(0).model_version(), plan->model_version());
  EXPECT_EQ(history->plans(0).objective(), plan->objective());
  EXPECT_EQ(history->plans(0).planned_by(), v1::STRATEGY_REC);
  EXPECT_EQ(history->plans(0).solver_status(), plan->solver_status());
  EXPECT_GT(history->plans(0).time().seconds(), 1'700'000'000);
  EXPECT_EQ(history->batch_errors_size(), 0);
  ASSERT_EQ(history->uncertainty_size(), 1);
  const v1::UncertaintyRecord first = history->uncertainty(0);
  ASSERT_EQ(first.mean_std_size(), 2);

  // The next batch, predicted by hand first.
  const std::vector<v1::Transition> batch = PendulumTransitions(6, 30, 11);
  v1::PredictRequest predict;
  predict.set_session(name);
  for (const v1::Transition& t : batch) {
    predict.add_inputs(t.state(0));
    predict.add_inputs(t.state(1));
    predict.add_inputs(t.input(0));
  }
  absl::StatusOr<v1::PredictResponse> predicted = client_->Predict(predict);
  ASSERT_TRUE(predicted.ok()) << predicted.status();
  double squares[2] = {0, 0};
  for (size_t i = 0; i < batch.size(); ++i) {
    for (int d = 0; d < 2; ++d) {
      squares[d] += std::pow(batch[i].next_state(d) - predicted->mean(2 * i + d), 2);
    }
  }
  Add(name, {batch});
  Add(name, {batch});  // duplicates only: not scored again
  history = client_->GetSessionHistory(name);
  ASSERT_TRUE(history.ok()) << history.status();
  ASSERT_EQ(history->batch_errors_size(), 1);
  const v1::BatchError& error = history->batch_errors(0);
  EXPECT_EQ(error.sample_count(), 30);
  EXPECT_EQ(error.batch_size(), 6);
  EXPECT_EQ(error.model_version(), predicted->model_version());
  ASSERT_EQ(error.rmse_size(), 2);
  for (int d = 0; d < 2; ++d) {
    const double expected = std::sqrt(squares[d] / 6);
    EXPECT_NEAR(error.rmse(d), expected, 1e-12 * expected) << d;
  }
  ASSERT_EQ(history->uncertainty_size(), 2);
  EXPECT_EQ(history->uncertainty(1).sample_count(), 36);
  for (int d = 0; d < 2; ++d) {
    EXPECT_GT(history->uncertainty(1).mean_std(d), 0.0);
    EXPECT_LT(history->uncertainty(1).mean_std(d), first.mean_std(d)) << d;
  }

  ASSERT_TRUE(client_->PlanInputs(name, {0.1, -0.2}).ok());
  history = client_->GetSessionHistory(name);
  ASSERT_TRUE(history.ok()) << history.status();
  ASSERT_EQ(history->plans_size(), 2);
  EXPECT_EQ(history->plans(1).sample_count(), 36);

  ExpectStatus(client_->GetSessionHistory("sessions/no-such").status(),
               absl::StatusCode::kNotFound, "no-such");
  ExpectStatus(client_->GetSessionHistory("history").status(),
               absl::StatusCode::kInvalidArgument, "name");
  // Kept in memory: a restart starts it again.
  StopServer();
  StartServer();
  history = client_->GetSessionHistory(name);
  ASSERT_TRUE(history.ok()) << history.status();
  EXPECT_EQ(history->plans_size(), 0);
  EXPECT_EQ(history->batch_errors_size(), 0);
}

// Rollout: step 0 is the given state with its variance; step 1's mean and
// variance are Predict's at (x_0, u_0) (plus the propagated x_0 variance);
// every covariance is symmetric; bad requests name their field.
TEST_F(ServiceTest, RolloutPropagatesTheStateDistribution) {
  const std::string name = Create("rollout").name();
  Add(name, {PendulumTransitions(40, 0, 3)});
  v1::RolloutRequest request;
  request.set_session(name);
  request.add_state(0.2);
  request.add_state(-0.4);
  for (double u : {1.0, -1.0, 0.5}) request.add_inputs(u);
  absl::StatusOr<v1::RolloutResponse> rolled = client_->Rollout(request);
  ASSERT_TRUE(rolled.ok()) << rolled.status();
  ASSERT_EQ(rolled->means_size(), 8);
  ASSERT_EQ(rolled->covariances_size(), 16);
  ASSERT_EQ(rolled->variances_size(), 8);
  EXPECT_EQ(rolled->means(0), 0.2);
  EXPECT_EQ(rolled->variances(0), 0.0);
  v1::PredictRequest predict;
  predict.set_session(name);
  for (double v : {0.2, -0.4, 1.0}) predict.add_inputs(v);
  absl::StatusOr<v1::PredictResponse> predicted = client_->Predict(predict);
  ASSERT_TRUE(predicted.ok()) << predicted.status();
  for (int j = 0; j < 2; ++j) {
    EXPECT_NEAR(rolled->means(2 + j), predicted->mean(j), 1e-12);
    EXPECT_NEAR(rolled->variances(2 + j), predicted->variance(j),
                1e-12 * predicted->variance(j));
  }
  for (int k = 0; k < 4; ++k) {
    EXPECT_EQ(rolled->covariances(4 * k + 1), rolled->covariances(4 * k + 2)) << k;
    EXPECT_EQ(rolled->variances(2 * k + 1), rolled->covariances(4 * k + 3)) << k;
    if (k > 0) {
      EXPECT_GT(rolled->variances(2 * k), rolled->variances(2 * k - 2));
    }
  }
  EXPECT_EQ(rolled->model_version(), predicted->model_version());

  // An uncertain start and the observation noise only widen it.
  request.add_state_variance(0.01);
  request.add_state_variance(0.02);
  request.set_include_noise(true);
  absl::StatusOr<v1::RolloutResponse> wider = client_->Rollout(request);
  ASSERT_TRUE(wider.ok()) << wider.status();
  EXPECT_EQ(wider->variances(1), 0.02);
  for (int i = 2; i < 8; ++i) EXPECT_GT(wider->variances(i), rolled->variances(i)) << i;

  v1::RolloutRequest bad = request;
  bad.set_state_variance(1, -1.0);
  ExpectStatus(client_->Rollout(bad).status(), absl::StatusCode::kInvalidArgument,
               "state_variance[1]");
  bad = request;
  bad.clear_inputs();
  ExpectStatus(client_->Rollout(bad).status(), absl::StatusCode::kInvalidArgument,
               "inputs: must hold 1 to 1000 steps");
  bad = request;
  bad.add_state(1.0);
  ExpectStatus(client_->Rollout(bad).status(), absl::StatusCode::kInvalidArgument,
               "state");
  bad = request;
  bad.set_session("sessions/nobody");
  ExpectStatus(client_->Rollout(bad).status(), absl::StatusCode::kNotFound, "nobody");
}

}  // namespace
}  // namespace excite::service
