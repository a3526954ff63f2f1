// State constraints (a safe box with a margin of kappa predictive standard
// deviations) on the real GP: the violation measure, the NLP's constraint rows
// under Ipopt's derivative checker, and plans of every model-based strategy that
// keep a box the unconstrained plans leave.
#include "server/plan/safe_box.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "server/gp/dynamics_model.h"
#include "server/plan/information_objectives.h"
#include "server/plan/multiple_shooting_nlp.h"
#include "server/plan/planner.h"
#include "tests/plan/pendulum_gp.h"

namespace excite::plan {
namespace {

using testing::CheckerStart;
using testing::DerivativeCheckerLog;
using testing::FittedModel;

SafeBox Box(double theta, double omega, double margin) {
  SafeBox box;
  box.lower = Eigen::Vector2d(-theta, -omega);
  box.upper = Eigen::Vector2d(theta, omega);
  box.margin = margin;
  return box;
}

TEST(SafeBoxTest, ViolationIsTheLargestExcessIncludingTheMargin) {
  const SafeBox box = Box(1.0, 2.0, 2.0);
  Eigen::MatrixXd mean(2, 2), variance(2, 2);
  mean << 0.0, 0.0, 0.5, -1.0;
  variance << 0.01, 0.04, 0.0625, 0.25;
  // Row 1: theta 0.5 + 2 * 0.25 = 1.0 (on the edge), omega -1 - 2 * 0.5 = -2.0.
  EXPECT_NEAR(SafeBoxViolation(box, mean, variance), 0.0, 1e-12);
  mean(1, 0) = 0.7;  // 0.7 + 0.5 - 1.0
  EXPECT_NEAR(SafeBoxViolation(box, mean, variance), 0.2, 1e-12);
  mean(0, 1) = -2.5;  // -2 - (-2.5 - 2 * 0.2)
  EXPECT_NEAR(SafeBoxViolation(box, mean, variance), 0.9, 1e-12);
  EXPECT_EQ(SafeBoxViolation(SafeBox{}, mean, variance), 0.0);
}

TEST(SafeBoxTest, IpoptDerivativeCheckerWithTheBoxRows) {
  const gp::DynamicsModel model = FittedModel(80);
  Eigen::MatrixXd inputs, states;
  CheckerStart(&inputs, &states);
  auto mi = NegativeMutualInformationObjective::Create(model);
  ASSERT_TRUE(mi.ok());
  Ipopt::SmartPtr<MultipleShootingNlp> nlp = new MultipleShootingNlp(
      model, **mi, Eigen::Vector2d(0.1, -0.2), Eigen::VectorXd::Constant(1, -3.0),
      Eigen::VectorXd::Constant(1, 3.0), inputs, states);
  nlp->SetSafeBox(Box(1.0, 3.0, 1.5));
  EXPECT_EQ(nlp->num_constraints(), 7 * 2 + 2 * 8 * 2);
  const std::string log = DerivativeCheckerLog(nlp);
  EXPECT_NE(log.find("No errors detected by derivative checker"), std::string::npos)
      << log;
}

// Every model-based strategy, from the bottom at rest, with a box that the
// unconstrained plan leaves: the constrained plan's predicted states keep it.
TEST(SafeBoxTest, EveryModelBasedStrategyKeepsTheBox) {
  const gp::DynamicsModel model = FittedModel(150);
  const Eigen::VectorXd x0 = Eigen::Vector2d(0.0, 0.0);
  const SafeBox box = Box(0.12, 0.2, 1.0);
  for (Strategy strategy :
       {Strategy::kRec, Strategy::kPa, Strategy::kGreedy, Strategy::kSep, Strategy::kMi,
        Strategy::kRoi, Strategy::kOptimistic}) {
    PlanOptions o;
    o.strategy = strategy;
    o.horizon = 10;
    o.input_lower = Eigen::VectorXd::Constant(1, -3.0);
    o.input_upper = Eigen::VectorXd::Constant(1, 3.0);
    o.state_lower = Eigen::Vector2d(-3.14159, -8.0);
    o.state_upper = Eigen::Vector2d(3.14159, 8.0);
    o.roi_reference_points = 64;
    PlanSummary free_summary;
    Planner free_planner(o);
    const auto free_plan =
        free_planner.PlanInputs(model, x0, 0, PlanLimits{}, &free_summary);
    ASSERT_TRUE(free_plan.ok()) << free_plan.status();

    o.safe_box = box;
    Planner planner(o);
    PlanSummary summary;
    const auto plan = planner.PlanInputs(model, x0, 0, PlanLimits{}, &summary);
    ASSERT_TRUE(plan.ok()) << plan.status();
    Eigen::MatrixXd mean, variance;
    Eigen::MatrixXd z(plan->inputs.rows(), 3);
    z << plan->states, plan->inputs;
    model.Predict(z, &mean, &variance, nullptr, nullptr);
    const double violation = SafeBoxViolation(box, mean, variance);
    EXPECT_EQ(violation, 0.0) << static_cast<int>(strategy);
    EXPECT_EQ(summary.safe_box_violation, 0.0);
    // The box binds: without it the same strategy goes outside (sep and greedy
    // plan too few steps to leave it, so only the others are required to).
    if (strategy != Strategy::kGreedy && strategy != Strategy::kSep) {
      Eigen::MatrixXd fz(free_plan->inputs.rows(), 3), fm, fv;
      fz << free_plan->states, free_plan->inputs;
      model.Predict(fz, &fm, &fv, nullptr, nullptr);
      EXPECT_GT(SafeBoxViolation(box, fm, fv), 0.05) << static_cast<int>(strategy);
    }
  }
}

TEST(SafeBoxTest, InvalidBoxIsRejected) {
  const gp::DynamicsModel model = FittedModel(40);
  PlanOptions o;
  o.input_lower = Eigen::VectorXd::Constant(1, -3.0);
  o.input_upper = Eigen::VectorXd::Constant(1, 3.0);
  o.safe_box = Box(1.0, 1.0, -1.0);
  Planner planner(o);
  PlanSummary summary;
  const auto plan =
      planner.PlanInputs(model, Eigen::Vector2d(0.0, 0.0), 0, PlanLimits{}, &summary);
  EXPECT_EQ(plan.status().code(), absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace excite::plan
