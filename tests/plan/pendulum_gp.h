#ifndef EXCITE_TESTS_PLAN_PENDULUM_GP_H_
#define EXCITE_TESTS_PLAN_PENDULUM_GP_H_

// A real gp::DynamicsModel fitted on noisy pendulum data, a starting trajectory
// and Ipopt's derivative checker, shared by the planner tests on the GP engine.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <random>
#include <string>

#include "server/gp/dynamics_model.h"
#include "server/plan/ipopt_solve.h"
#include "server/plan/multiple_shooting_nlp.h"

namespace excite::plan::testing {

// theta'' = -(g/l) sin(theta) - b/(m l^2) theta' + u/(m l^2), m = l = 1, b = 0.1;
// dt = 0.1 s by 10 RK4 steps (as sim/configs/pendulum.textproto).
inline Eigen::Vector2d PendulumStep(const Eigen::Vector2d& x, double u) {
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

inline gp::DynamicsModel FittedModel(int n) {
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

// A smooth, non-trivial starting trajectory of 8 steps for the derivative checks.
inline void CheckerStart(Eigen::MatrixXd* inputs, Eigen::MatrixXd* states) {
  constexpr int kHorizon = 8;
  inputs->resize(kHorizon, 1);
  states->resize(kHorizon, 2);
  for (int i = 0; i < kHorizon; ++i) {
    (*inputs)(i, 0) = 2.5 * std::sin(0.9 * i);
    states->row(i) << 0.3 * std::cos(0.5 * i), 1.5 * std::sin(0.7 * i);
  }
}

// Ipopt's first-order derivative checker at the NLP's starting point: its log.
inline std::string DerivativeCheckerLog(const Ipopt::SmartPtr<MultipleShootingNlp>& nlp) {
  IpoptSettings settings;
  settings.max_iterations = 0;
  settings.string_options = {{"derivative_test", "first-order"},
                             {"derivative_test_print_all", "no"}};
  std::string log;
  settings.log = &log;
  SolveTnlp(nlp, settings);
  return log;
}

}  // namespace excite::plan::testing

#endif  // EXCITE_TESTS_PLAN_PENDULUM_GP_H_
