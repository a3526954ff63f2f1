#include "sim/plants/rk4.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>

#include "sim/plants/pendulum.h"

namespace excite::sim {
namespace {

// Harmonic oscillator x' = A x with A = [[0, 1], [-1, 0]]: the exact solution is a
// rotation, x(t) = [[cos t, sin t], [-sin t, cos t]] x(0).
Eigen::VectorXd Oscillator(const Eigen::VectorXd& x) {
  Eigen::VectorXd dx(2);
  dx << x(1), -x(0);
  return dx;
}

Eigen::VectorXd OscillatorExact(const Eigen::VectorXd& x0, double t) {
  Eigen::VectorXd x(2);
  x << std::cos(t) * x0(0) + std::sin(t) * x0(1),
      -std::sin(t) * x0(0) + std::cos(t) * x0(1);
  return x;
}

TEST(Rk4Test, ExactForLinearRightHandSideOfDegreeZero) {
  // x' = 3 (constant): RK4 is exact.
  const auto f = [](const Eigen::VectorXd& x) -> Eigen::VectorXd {
    return Eigen::VectorXd::Constant(x.size(), 3.0);
  };
  const Eigen::VectorXd x = Rk4Integrate(f, Eigen::VectorXd::Zero(1), 2.0, 3);
  EXPECT_NEAR(x(0), 6.0, 1e-12);
}

TEST(Rk4Test, FourthOrderOnLinearOde) {
  Eigen::VectorXd x0(2);
  x0 << 1.0, 0.5;
  const double duration = 2.0;
  const Eigen::VectorXd exact = OscillatorExact(x0, duration);
  for (int steps : {10, 20, 40}) {
    const double error_coarse =
        (Rk4Integrate(Oscillator, x0, duration, steps) - exact).norm();
    const double error_fine =
        (Rk4Integrate(Oscillator, x0, duration, 2 * steps) - exact).norm();
    const double ratio = error_coarse / error_fine;
    EXPECT_NEAR(ratio, 16.0, 1.0) << "steps " << steps;
  }
}

TEST(Rk4Test, FourthOrderOnScalarDecay) {
  // x' = -x, x(t) = exp(-t) x(0).
  const auto f = [](const Eigen::VectorXd& x) -> Eigen::VectorXd { return -x; };
  const Eigen::VectorXd x0 = Eigen::VectorXd::Constant(1, 2.0);
  const double exact = 2.0 * std::exp(-3.0);
  const double e1 = std::abs(Rk4Integrate(f, x0, 3.0, 64)(0) - exact);
  const double e2 = std::abs(Rk4Integrate(f, x0, 3.0, 128)(0) - exact);
  EXPECT_NEAR(e1 / e2, 16.0, 1.0);
}

TEST(Rk4Test, PendulumConvergesWithFourthOrderToFineReference) {
  const PendulumParameters parameters;  // m = l = 1, b = 0.1, g = 9.81.
  // One long sampling period so that the error is well above round-off.
  const double dt = 1.0;
  const Pendulum coarse(parameters, dt, 40);
  const Pendulum fine(parameters, dt, 80);
  const Pendulum reference(parameters, dt, 20000);
  const Eigen::VectorXd x = Eigen::Vector2d(2.5, -1.0);
  const Eigen::VectorXd u = Eigen::VectorXd::Constant(1, 1.5);
  const Eigen::VectorXd x_ref = reference.Step(x, u);
  const double e_coarse = (coarse.Step(x, u) - x_ref).norm();
  const double e_fine = (fine.Step(x, u) - x_ref).norm();
  EXPECT_GT(e_coarse, 1e-9);  // Not round-off.
  EXPECT_NEAR(e_coarse / e_fine, 16.0, 1.5);
}

}  // namespace
}  // namespace excite::sim
