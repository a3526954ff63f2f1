// sep's steering: the multiple-shooting NLP with SteeringObjective, its
// derivatives (ours and Ipopt's checker) and a solve on the analytic pendulum.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "server/plan/ipopt_solve.h"
#include "server/plan/multiple_shooting_nlp.h"
#include "server/plan/rollout.h"
#include "server/plan/shooting_solver.h"
#include "server/plan/steering_objective.h"
#include "tests/plan/analytic_predictor.h"

namespace excite::plan {
namespace {

using ::excite::plan::testing::AnalyticPendulum;
using ::excite::plan::testing::WrappedPredictor;

SteeringObjective Objective() {
  return SteeringObjective(Eigen::Vector2d(0.6, 0.9), Eigen::Vector2d(1.0, 0.25));
}

// An NLP at a generic point: inputs inside the bounds, states off the dynamics.
Ipopt::SmartPtr<MultipleShootingNlp> MakeNlp(const gp::DynamicsPredictor& model,
                                             const SteeringObjective& objective,
                                             int horizon) {
  const int du = model.input_dim();
  Eigen::MatrixXd inputs = Eigen::MatrixXd::Random(horizon, du) * 1.5;
  Eigen::MatrixXd states = Eigen::MatrixXd::Random(horizon, 2);
  return new MultipleShootingNlp(model, objective, Eigen::Vector2d(0.2, -0.1),
                                 Eigen::VectorXd::Constant(du, -2.0),
                                 Eigen::VectorXd::Constant(du, 2.0), inputs, states);
}

TEST(SteeringObjectiveTest, ValueOnARolloutIsTheSumOfDistances) {
  const AnalyticPendulum model(1);
  const SteeringObjective objective = Objective();
  Eigen::MatrixXd inputs(6, 1);
  inputs << 0.5, -0.3, 1.0, 1.2, -1.0, 0.0;
  const Rollout r = RollOut(model, Eigen::Vector2d(0.1, 0.2), inputs);
  ASSERT_TRUE(r.valid);
  double expected = 0.0;
  for (int i = 0; i < 6; ++i) {
    const Eigen::Vector2d x = r.means.row(i).transpose();  // x_1 .. x_6
    expected += std::pow(x(0) - 0.6, 2) + 0.25 * std::pow(x(1) - 0.9, 2);
  }
  EXPECT_NEAR(RolloutObjective(objective, r), expected, 1e-12);
}

TEST(SteeringNlpTest, DerivativesMatchCentralDifferences) {
  const SteeringObjective objective = Objective();
  for (int du : {1, 2}) {
    for (int horizon : {1, 2, 6}) {
      SCOPED_TRACE(::testing::Message() << "du=" << du << " M=" << horizon);
      const AnalyticPendulum model(du);
      auto nlp = MakeNlp(model, objective, horizon);
      const Eigen::VectorXd w = nlp->StartingPoint();
      const int n = nlp->num_variables();
      Eigen::VectorXd grad(n);
      double f = 0.0;
      ASSERT_TRUE(nlp->eval_f(n, w.data(), true, f));
      ASSERT_TRUE(nlp->eval_grad_f(n, w.data(), false, grad.data()));
      const double h = 1e-6;
      for (int k = 0; k < n; ++k) {
        Eigen::VectorXd wp = w, wm = w;
        wp(k) += h;
        wm(k) -= h;
        double fp = 0.0, fm = 0.0;
        ASSERT_TRUE(nlp->eval_f(n, wp.data(), true, fp));
        ASSERT_TRUE(nlp->eval_f(n, wm.data(), true, fm));
        const double fd = (fp - fm) / (2 * h);
        EXPECT_NEAR(grad(k), fd, 1e-6 * std::max(1.0, std::abs(fd))) << "k=" << k;
      }
    }
  }
}

std::string DerivativeCheckerLog(const gp::DynamicsPredictor& model, int horizon) {
  const SteeringObjective objective = Objective();
  auto nlp = MakeNlp(model, objective, horizon);
  IpoptSettings settings;
  settings.max_iterations = 0;
  settings.string_options = {{"derivative_test", "first-order"},
                             {"derivative_test_print_all", "no"}};
  std::string log;
  settings.log = &log;
  settings.log_level = 4;
  EXPECT_TRUE(SolveTnlp(nlp, settings).options_accepted);
  return log;
}

TEST(SteeringNlpTest, IpoptDerivativeCheckerFindsNoErrors) {
  for (int horizon : {1, 6}) {
    const AnalyticPendulum model(2);
    const std::string log = DerivativeCheckerLog(model, horizon);
    EXPECT_NE(log.find("No errors detected by derivative checker"), std::string::npos)
        << log;
    EXPECT_EQ(log.find("Derivative checker detected"), std::string::npos) << log;
  }
}

// The terminal cost goes through the mean's Jacobian: a wrong one is caught in
// grad_f (with M = 1 there are no constraints, so only the objective can show it).
TEST(SteeringNlpTest, IpoptDerivativeCheckerCatchesWrongTerminalGradient) {
  const AnalyticPendulum model(2);
  const WrappedPredictor wrong_mean(model, 1.2, 1.0);
  const std::string log = DerivativeCheckerLog(wrong_mean, 1);
  EXPECT_NE(log.find("Derivative checker detected"), std::string::npos) << log;
  EXPECT_NE(log.find("grad_f"), std::string::npos) << log;
}

TEST(SteeringNlpTest, SolveBringsTheMeanStateCloserToTheTarget) {
  const AnalyticPendulum model(1);
  const Eigen::Vector2d x0(0.0, 0.0);
  const Eigen::Vector2d target(0.4, 1.0);
  const SteeringObjective objective(target, Eigen::Vector2d(1.0, 1.0));
  const Eigen::VectorXd lower = Eigen::VectorXd::Constant(1, -1.5);
  const Eigen::VectorXd upper = Eigen::VectorXd::Constant(1, 1.5);
  const int horizon = 12;
  // Start: zero inputs (the pendulum stays at rest, far from the target).
  std::vector<Eigen::MatrixXd> starts = {Eigen::MatrixXd::Zero(horizon, 1)};
  const Rollout start = RollOut(model, x0, starts[0]);
  const double start_value = RolloutObjective(objective, start);
  ShootingSettings settings;
  settings.max_iterations = 200;
  const ShootingResult result =
      SolveFromStarts(model, objective, x0, lower, upper, starts, settings, nullptr);
  ASSERT_TRUE(result.best.valid);
  EXPECT_EQ(result.starts, 1);
  EXPECT_EQ(result.status, PlanStatus::kConverged);
  EXPECT_LT(result.value, 0.5 * start_value);
  EXPECT_GE(result.best.inputs.minCoeff(), -1.5);
  EXPECT_LE(result.best.inputs.maxCoeff(), 1.5);
  // Some predicted state gets much closer to x* than x0 is, and the horizon ends
  // closer than it started.
  double closest = objective.Distance(x0);
  for (int i = 0; i < horizon; ++i) {
    closest = std::min(closest, objective.Distance(result.best.means.row(i).transpose()));
  }
  EXPECT_LT(closest, 0.1 * objective.Distance(x0));
  EXPECT_LT(objective.Distance(result.best.means.row(horizon - 1).transpose()),
            objective.Distance(x0));
  RecordProperty("closest_distance", std::to_string(closest));
  RecordProperty("start_distance", std::to_string(objective.Distance(x0)));
}

}  // namespace
}  // namespace excite::plan
