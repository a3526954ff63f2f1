#include "sim/plants/pendulum.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>

namespace excite::sim {
namespace {

const Eigen::VectorXd kNoTorque = Eigen::VectorXd::Zero(1);

TEST(PendulumTest, Dimensions) {
  const Pendulum pendulum(PendulumParameters{}, 0.1, 10);
  EXPECT_EQ(pendulum.name(), "pendulum");
  EXPECT_EQ(pendulum.state_dim(), 2);
  EXPECT_EQ(pendulum.input_dim(), 1);
}

TEST(PendulumTest, HangingEquilibriumIsFixedPoint) {
  const Pendulum pendulum(PendulumParameters{}, 0.1, 10);
  const Eigen::VectorXd next = pendulum.Step(Eigen::Vector2d::Zero(), kNoTorque);
  EXPECT_EQ(next(0), 0.0);
  EXPECT_EQ(next(1), 0.0);
}

TEST(PendulumTest, DampedUnforcedComesToRestAndEnergyNeverIncreases) {
  PendulumParameters parameters;
  parameters.damping = 0.5;  // Time constant 2 m l^2 / b = 4 s.
  const Pendulum pendulum(parameters, 0.1, 10);
  Eigen::VectorXd x = Eigen::Vector2d(2.0, 1.0);
  double energy = pendulum.Energy(x);
  for (int k = 0; k < 1500; ++k) {  // 150 s.
    x = pendulum.Step(x, kNoTorque);
    const double next_energy = pendulum.Energy(x);
    ASSERT_LE(next_energy, energy + 1e-12) << "step " << k;
    energy = next_energy;
  }
  EXPECT_NEAR(x(0), 0.0, 1e-6);
  EXPECT_NEAR(x(1), 0.0, 1e-6);
}

TEST(PendulumTest, SmallAngleMatchesLinearisedClosedForm) {
  // theta'' + 2 a theta' + w^2 theta = 0 with w^2 = g / l, a = b / (2 m l^2):
  // theta(t) = exp(-a t) (theta0 cos(wd t) + a theta0 / wd sin(wd t)),
  // wd = sqrt(w^2 - a^2), for theta(0) = theta0, theta'(0) = 0.
  PendulumParameters parameters;
  parameters.mass_kg = 0.5;
  parameters.length_m = 0.8;
  parameters.damping = 0.05;
  const double dt = 0.05;
  const Pendulum pendulum(parameters, dt, 10);
  const double theta0 = 1e-3;
  const double w2 = parameters.gravity / parameters.length_m;
  const double a = parameters.damping /
                   (2.0 * parameters.mass_kg * parameters.length_m * parameters.length_m);
  const double wd = std::sqrt(w2 - a * a);
  Eigen::VectorXd x = Eigen::Vector2d(theta0, 0.0);
  for (int k = 1; k <= 100; ++k) {  // 5 s, several periods.
    x = pendulum.Step(x, kNoTorque);
    const double t = k * dt;
    const double expected = std::exp(-a * t) * (theta0 * std::cos(wd * t) +
                                                a * theta0 / wd * std::sin(wd * t));
    // Nonlinearity error ~ theta0^3; integration error ~ (dt/10)^4.
    ASSERT_NEAR(x(0), expected, 1e-3 * theta0) << "t = " << t;
  }
}

TEST(PendulumTest, ConstantTorqueSettlesWhereGravityBalancesIt) {
  // m g l sin(theta*) = u.
  PendulumParameters parameters;
  parameters.damping = 1.0;
  const Pendulum pendulum(parameters, 0.1, 10);
  const double theta_star = 0.3;
  const Eigen::VectorXd u =
      Eigen::VectorXd::Constant(1, parameters.mass_kg * parameters.gravity *
                                       parameters.length_m * std::sin(theta_star));
  Eigen::VectorXd x = Eigen::Vector2d::Zero();
  for (int k = 0; k < 600; ++k) x = pendulum.Step(x, u);
  EXPECT_NEAR(x(0), theta_star, 1e-6);
  EXPECT_NEAR(x(1), 0.0, 1e-6);
}

}  // namespace
}  // namespace excite::sim
