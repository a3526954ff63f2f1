// Planner dispatch for prbs, chirp, random and sep (rec, pa and greedy:
// planner_test.cc).
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "server/plan/chirp_signal.h"
#include "server/plan/entropy_objective.h"
#include "server/plan/entropy_search.h"
#include "server/plan/planner.h"
#include "server/plan/prbs_signal.h"
#include "server/plan/random_signal.h"
#include "tests/plan/analytic_predictor.h"

namespace excite::plan {
namespace {

using ::excite::plan::testing::AnalyticPendulum;

// A model that must not be evaluated: counts Predict calls and returns NaN.
class UnfittedModel : public gp::DynamicsPredictor {
 public:
  int state_dim() const override { return 2; }
  int input_dim() const override { return 2; }
  void Predict(const Eigen::MatrixXd& z, Eigen::MatrixXd* mean, Eigen::MatrixXd* variance,
               std::vector<Eigen::MatrixXd>*,
               std::vector<Eigen::MatrixXd>*) const override {
    ++calls;
    if (mean != nullptr) *mean = Eigen::MatrixXd::Constant(z.rows(), 2, NAN);
    if (variance != nullptr) *variance = Eigen::MatrixXd::Constant(z.rows(), 2, NAN);
  }
  mutable std::atomic<int> calls{0};
};

PlanOptions Options(Strategy strategy, int du = 1, int horizon = 10) {
  PlanOptions o;
  o.strategy = strategy;
  o.horizon = horizon;
  o.input_lower = Eigen::VectorXd::Constant(du, -1.0);
  o.input_upper = Eigen::VectorXd::Constant(du, 1.5);
  o.state_lower = Eigen::Vector2d(-1.0, -2.0);
  o.state_upper = Eigen::Vector2d(1.0, 2.0);
  o.seed = 5;
  o.max_iterations = 50;
  return o;
}

TEST(PlannerStrategiesTest, ModelFreeStrategiesNeverEvaluateTheModel) {
  for (Strategy strategy : {Strategy::kPrbs, Strategy::kChirp, Strategy::kRandom}) {
    SCOPED_TRACE(static_cast<int>(strategy));
    const UnfittedModel model;
    Planner planner(Options(strategy, 2, 12));
    PlanSummary summary;
    const auto plan =
        planner.PlanInputs(model, Eigen::Vector2d(0.3, 0.4), 0, PlanLimits{}, &summary);
    ASSERT_TRUE(plan.ok()) << plan.status();
    EXPECT_EQ(model.calls, 0);
    ASSERT_EQ(plan->inputs.rows(), 12);
    ASSERT_EQ(plan->inputs.cols(), 2);
    EXPECT_EQ(plan->apply_count, 12);
    EXPECT_EQ(plan->states.rows(), 0);
    EXPECT_EQ(plan->variances.rows(), 0);
    EXPECT_EQ(summary.status, PlanStatus::kConverged);
    EXPECT_EQ(summary.objective, 0.0);
    EXPECT_EQ(summary.iterations, 0);
    EXPECT_GE(plan->inputs.minCoeff(), -1.0);
    EXPECT_LE(plan->inputs.maxCoeff(), 1.5);
  }
}

// The time index places the horizon in the signal: consecutive calls at k = 0,
// 12, 24 give the signal's samples 0..35, whatever planner object is used.
TEST(PlannerStrategiesTest, TimeIndexContinuesTheSignal) {
  const UnfittedModel model;
  PlanOptions o = Options(Strategy::kPrbs, 2, 12);
  o.signal.prbs_min_hold = 5;
  Eigen::MatrixXd joined(36, 2);
  for (int call = 0; call < 3; ++call) {
    Planner fresh(o);  // a "restarted" session
    const auto plan =
        fresh.PlanInputs(model, Eigen::Vector2d(0, 0), 12 * call, PlanLimits{}, nullptr);
    ASSERT_TRUE(plan.ok()) << plan.status();
    joined.middleRows(12 * call, 12) = plan->inputs;
  }
  EXPECT_EQ(joined, PrbsSignal(o.input_lower, o.input_upper, 5, o.seed, 0, 36));

  o.strategy = Strategy::kChirp;
  o.signal.chirp_start_frequency = 0.05;
  o.signal.chirp_end_frequency = 0.25;
  o.signal.chirp_period = 40;
  Planner chirp(o);
  const auto plan = chirp.PlanInputs(model, Eigen::Vector2d(0, 0), 30, {}, nullptr);
  ASSERT_TRUE(plan.ok());
  EXPECT_EQ(plan->inputs, ChirpSignal(o.input_lower, o.input_upper,
                                      ChirpParams{0.05, 0.25, 40}, 30, 12));

  o.strategy = Strategy::kRandom;
  o.signal.random_hold = 4;
  Planner random(o);
  const auto random_plan =
      random.PlanInputs(model, Eigen::Vector2d(0, 0), 7, {}, nullptr);
  ASSERT_TRUE(random_plan.ok());
  EXPECT_EQ(random_plan->inputs,
            RandomSignal(o.input_lower, o.input_upper, 4, o.seed, 7, 12));
}

TEST(PlannerStrategiesTest, InvalidSignalOptionsAndTimeIndex) {
  const UnfittedModel model;
  PlanOptions o = Options(Strategy::kPrbs, 2);
  o.signal.prbs_min_hold = 0;
  EXPECT_EQ(
      Planner(o).PlanInputs(model, Eigen::Vector2d(0, 0), 0, {}, nullptr).status().code(),
      absl::StatusCode::kInvalidArgument);
  o = Options(Strategy::kChirp, 2);
  o.signal.chirp_period = 0;
  EXPECT_EQ(
      Planner(o).PlanInputs(model, Eigen::Vector2d(0, 0), 0, {}, nullptr).status().code(),
      absl::StatusCode::kInvalidArgument);
  o = Options(Strategy::kRandom, 2);
  EXPECT_EQ(Planner(o)
                .PlanInputs(model, Eigen::Vector2d(0, 0), -1, {}, nullptr)
                .status()
                .code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(PlannerStrategiesTest, EveryStrategyRespectsTheInputBounds) {
  for (Strategy strategy :
       {Strategy::kRec, Strategy::kPa, Strategy::kGreedy, Strategy::kPrbs,
        Strategy::kChirp, Strategy::kRandom, Strategy::kSep}) {
    for (int du : {1, 2}) {
      SCOPED_TRACE(::testing::Message()
                   << "strategy " << static_cast<int>(strategy) << " du " << du);
      const AnalyticPendulum model(du);
      Planner planner(Options(strategy, du, 8));
      Eigen::VectorXd x = Eigen::Vector2d(0.1, -0.2);
      for (int call = 0; call < 3; ++call) {
        const auto plan = planner.PlanInputs(model, x, 8 * call, PlanLimits{}, nullptr);
        ASSERT_TRUE(plan.ok()) << plan.status();
        ASSERT_GE(plan->inputs.rows(), 1);
        ASSERT_EQ(plan->inputs.cols(), du);
        EXPECT_TRUE(plan->inputs.allFinite());
        EXPECT_GE(plan->inputs.minCoeff(), -1.0);
        EXPECT_LE(plan->inputs.maxCoeff(), 1.5);
        EXPECT_GE(plan->apply_count, 1);
        EXPECT_LE(plan->apply_count, plan->inputs.rows());
        if (plan->states.rows() > 0) x = plan->states.bottomRows(1).transpose();
      }
    }
  }
}

TEST(PlannerStrategiesTest, SepNeedsStateBounds) {
  const AnalyticPendulum model(1);
  PlanOptions o = Options(Strategy::kSep);
  o.state_lower.resize(0);
  o.state_upper.resize(0);
  const auto plan = Planner(o).PlanInputs(model, Eigen::Vector2d(0, 0), 0, {}, nullptr);
  EXPECT_EQ(plan.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(plan.status().message().find("state bounds"), std::string::npos);
}

TEST(PlannerStrategiesTest, SepSearchesSteersAndAppliesTheTargetInput) {
  const AnalyticPendulum model(1);
  const int horizon = 10;
  PlanOptions o = Options(Strategy::kSep, 1, horizon);
  Planner planner(o);
  const Eigen::VectorXd x0 = Eigen::Vector2d(0.1, 0.0);
  PlanSummary summary;
  const auto plan = planner.PlanInputs(model, x0, 0, PlanLimits{}, &summary);
  ASSERT_TRUE(plan.ok()) << plan.status();
  const int rows = static_cast<int>(plan->inputs.rows());
  ASSERT_GE(rows, 1);
  ASSERT_LE(rows, horizon + 1);
  EXPECT_EQ(plan->apply_count, rows);
  ASSERT_EQ(plan->states.rows(), rows);
  ASSERT_EQ(plan->variances.rows(), rows);
  EXPECT_EQ(plan->states.row(0), x0.transpose());

  // z* lies in the box and beats 1000 random points of it.
  ASSERT_EQ(summary.search_point.size(), 3);
  Eigen::VectorXd box_lower(3), box_upper(3);
  box_lower << o.state_lower, o.input_lower;
  box_upper << o.state_upper, o.input_upper;
  EXPECT_TRUE((summary.search_point.array() >= box_lower.array()).all());
  EXPECT_TRUE((summary.search_point.array() <= box_upper.array()).all());
  std::mt19937_64 rng(17);
  for (int s = 0; s < 1000; ++s) {
    Eigen::VectorXd z(3);
    for (int l = 0; l < 3; ++l) {
      z(l) = std::uniform_real_distribution<double>(box_lower(l), box_upper(l))(rng);
    }
    ASSERT_GE(summary.search_entropy, PointEntropy(model, z, nullptr));
  }
  // The last input is u*; the state it is applied in is the predicted state
  // closest to x* (so no farther than x0).
  EXPECT_EQ(plan->inputs(rows - 1, 0), summary.search_point(2));
  const Eigen::Vector2d target = summary.search_point.head(2);
  const Eigen::Vector2d scale = 0.5 * (o.state_upper - o.state_lower);
  const auto distance = [&](const Eigen::VectorXd& x) {
    return (x - target).cwiseQuotient(scale).squaredNorm();
  };
  EXPECT_LE(distance(plan->states.bottomRows(1).transpose()), distance(x0) + 1e-12);
  EXPECT_NEAR(summary.objective, Entropy(plan->variances), 1e-12);
  EXPECT_GT(summary.iterations, 0);
  RecordProperty("sep_rows", std::to_string(rows));
  RecordProperty("sep_distance_start", std::to_string(distance(x0)));
  RecordProperty("sep_distance_end",
                 std::to_string(distance(plan->states.bottomRows(1).transpose())));
}

TEST(PlannerStrategiesTest, SepCancelledBeforeStartIsCancelled) {
  const AnalyticPendulum model(1);
  Planner planner(Options(Strategy::kSep));
  PlanLimits limits;
  limits.cancelled = [] { return true; };
  EXPECT_EQ(planner.PlanInputs(model, Eigen::Vector2d(0, 0), 0, limits, nullptr)
                .status()
                .code(),
            absl::StatusCode::kCancelled);
}

TEST(PlannerStrategiesTest, SepPastDeadlineStillReturnsAFeasiblePlan) {
  const AnalyticPendulum model(1);
  Planner planner(Options(Strategy::kSep));
  PlanLimits limits;
  limits.deadline = std::chrono::steady_clock::now();
  PlanSummary summary;
  const auto plan = planner.PlanInputs(model, Eigen::Vector2d(0, 0), 0, limits, &summary);
  ASSERT_TRUE(plan.ok()) << plan.status();
  EXPECT_EQ(summary.status, PlanStatus::kTimeLimit);
  EXPECT_EQ(summary.starts, 0);
  EXPECT_GE(plan->inputs.minCoeff(), -1.0);
  EXPECT_LE(plan->inputs.maxCoeff(), 1.5);
}

}  // namespace
}  // namespace excite::plan
