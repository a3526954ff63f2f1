// The planner on a real gp::DynamicsModel fitted on pendulum data (the analytic
// stand-in of the other tests replaced by the GP engine).
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <random>
#include <string>

#include "server/gp/dynamics_model.h"
#include "server/plan/entropy_objective.h"
#include "server/plan/ipopt_solve.h"
#include "server/plan/multiple_shooting_nlp.h"
#include "server/plan/planner.h"

namespace excite::plan {
namespace {

// theta'' = -(g/l) sin(theta) - b/(m l^2) theta' + u/(m l^2), m = l = 1, b = 0.1;
// dt = 0.1 s by 10 RK4 steps (as sim/configs/pendulum.textproto).
Eigen::Vector2d PendulumStep(const Eigen::Vector2d& x, double u) {
  const auto f = [u](const Eigen::Vector2d& s) {
    return Eigen::Vector2d(s(1), -9.81 * std::sin(s(0)) - 0.1 * s(1) + u);
  };
  Eigen::Vector2d s = x;
  const double h = 0.01;
  for (int k = 0; k < 10; ++k) {
    const Eigen::Vector2d k1 = f(s), k2 = f(s + 0.5 * h * k1), k3 = f(s + 0.5 * h * k2),
                          k4 = f(s + h * k3);
    s += h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4);
  }
  return s;
}

gp::DynamicsModel FittedModel(int n) {
  gp::DynamicsModelOptions o;
  o.state_dim = 2;
  o.input_dim = 1;
  o.measurement_noise_variance = 0.05;
  o.input_center = Eigen::Vector3d(0.0, 0.0, 0.0);
  o.input_half_width = Eigen::Vector3d(3.14159, 8.0, 3.0);
  auto model = gp::DynamicsModel::Create(o);
  EXPECT_TRUE(model.ok()) << model.status();
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> input(-3.0, 3.0);
  std::normal_distribution<double> noise(0.0, std::sqrt(0.05));
  Eigen::MatrixXd states(n, 2), inputs(n, 1), next(n, 2);
  Eigen::Vector2d x(0.0, 0.0);
  double u = 0.0;
  for (int k = 0; k < n; ++k) {
    if (k % 5 == 0) u = input(rng);  // random input held 5 steps
    const Eigen::Vector2d x1 = PendulumStep(x, u);
    states.row(k) = (x + Eigen::Vector2d(noise(rng), noise(rng))).transpose();
    inputs(k, 0) = u;
    next.row(k) = (x1 + Eigen::Vector2d(noise(rng), noise(rng))).transpose();
    x = x1;
  }
  EXPECT_TRUE(model->AddSamples(states, inputs, next).ok());
  EXPECT_TRUE(model->Refit().ok());
  return *std::move(model);
}

TEST(PlannerGpTest, IpoptDerivativeCheckerOnTheGp) {
  const gp::DynamicsModel model = FittedModel(80);
  const int horizon = 8;
  Eigen::MatrixXd inputs(horizon, 1), states(horizon, 2);
  for (int i = 0; i < horizon; ++i) {
    inputs(i, 0) = 2.5 * std::sin(0.9 * i);
    states.row(i) << 0.3 * std::cos(0.5 * i), 1.5 * std::sin(0.7 * i);
  }
  Ipopt::SmartPtr<MultipleShootingNlp> nlp = new MultipleShootingNlp(
      model, Eigen::Vector2d(0.1, -0.2), Eigen::VectorXd::Constant(1, -3.0),
      Eigen::VectorXd::Constant(1, 3.0), inputs, states);
  IpoptSettings settings;
  settings.max_iterations = 0;
  settings.string_options = {{"derivative_test", "first-order"},
                             {"derivative_test_print_all", "no"}};
  std::string log;
  settings.log = &log;
  SolveTnlp(nlp, settings);
  EXPECT_NE(log.find("No errors detected by derivative checker"), std::string::npos)
      << log;
}

TEST(PlannerGpTest, RecPlanBeatsRandomSequences) {
  const gp::DynamicsModel model = FittedModel(150);
  PlanOptions o;
  o.strategy = Strategy::kRec;
  o.horizon = 15;
  o.input_lower = Eigen::VectorXd::Constant(1, -3.0);
  o.input_upper = Eigen::VectorXd::Constant(1, 3.0);
  Planner planner(o);
  const Eigen::VectorXd x0 = Eigen::Vector2d(0.0, 0.0);
  PlanSummary summary;
  const auto plan = planner.PlanInputs(model, x0, PlanLimits{}, &summary);
  ASSERT_TRUE(plan.ok()) << plan.status();
  ASSERT_EQ(plan->inputs.rows(), 15);
  EXPECT_TRUE(plan->inputs.allFinite());
  EXPECT_LE(plan->inputs.maxCoeff(), 3.0);
  EXPECT_GE(plan->inputs.minCoeff(), -3.0);
  EXPECT_NEAR(summary.objective, Entropy(plan->variances), 1e-9);

  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  double best_random = -1e300;
  for (int r = 0; r < 100; ++r) {
    Eigen::VectorXd x = x0;
    Eigen::MatrixXd variances(15, 2);
    for (int i = 0; i < 15; ++i) {
      Eigen::MatrixXd z(1, 3), mean, var;
      z << x.transpose(), u(rng);
      model.Predict(z, &mean, &var, nullptr, nullptr);
      variances.row(i) = var.row(0);
      x = mean.row(0).transpose();
    }
    best_random = std::max(best_random, Entropy(variances));
  }
  EXPECT_GE(summary.objective, best_random);
  RecordProperty("planned_entropy", std::to_string(summary.objective));
  RecordProperty("best_random_entropy", std::to_string(best_random));
  RecordProperty("plan_ms", std::to_string(summary.wall_time_ms));
  RecordProperty("iterations", std::to_string(summary.iterations));

  // A second (warm-started) call from the predicted next state.
  const auto second =
      planner.PlanInputs(model, plan->states.row(1).transpose(), PlanLimits{}, &summary);
  ASSERT_TRUE(second.ok()) << second.status();
  EXPECT_EQ(second->inputs.rows(), 15);
}

}  // namespace
}  // namespace excite::plan
