#include "sim/plants/unicycle.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>

namespace excite::sim {
namespace {

Eigen::VectorXd State(double px, double py, double psi, double v, double w, double r) {
  Eigen::VectorXd x(6);
  x << px, py, psi, v, w, r;
  return x;
}

TEST(UnicycleTest, Dimensions) {
  const Unicycle unicycle(UnicycleParameters{}, 0.1, 10);
  EXPECT_EQ(unicycle.name(), "unicycle");
  EXPECT_EQ(unicycle.state_dim(), 6);
  EXPECT_EQ(unicycle.input_dim(), 2);
}

TEST(UnicycleTest, RestIsFixedPoint) {
  const Unicycle unicycle(UnicycleParameters{}, 0.1, 10);
  const Eigen::VectorXd x = State(1.0, -2.0, 0.7, 0, 0, 0);
  EXPECT_EQ((unicycle.Step(x, Eigen::Vector2d::Zero()) - x).norm(), 0.0);
}

TEST(UnicycleTest, SymmetricForcesDriveStraightWithClosedFormSpeed) {
  // F_left = F_right = F/2: no torque, so psi stays, w and r stay 0, and
  // v(t) = (F / b)(1 - exp(-b t / m)), s(t) = (F / b)(t - m / b (1 - exp(-b t / m))).
  const UnicycleParameters p;
  const double dt = 0.1;
  const Unicycle unicycle(p, dt, 10);
  const double psi = 0.6;
  const double force = 1.5;
  Eigen::VectorXd x = State(0.0, 0.0, psi, 0, 0, 0);
  const Eigen::VectorXd u = Eigen::Vector2d(force / 2, force / 2);
  for (int k = 1; k <= 50; ++k) {
    x = unicycle.Step(x, u);
    const double t = k * dt;
    const double tau = p.mass_kg / p.forward_damping;
    const double v = force / p.forward_damping * (1 - std::exp(-t / tau));
    const double s = force / p.forward_damping * (t - tau * (1 - std::exp(-t / tau)));
    ASSERT_NEAR(x(3), v, 1e-7) << "t = " << t;
    ASSERT_NEAR(x(0), s * std::cos(psi), 1e-7);
    ASSERT_NEAR(x(1), s * std::sin(psi), 1e-7);
    ASSERT_EQ(x(2), psi);
    ASSERT_EQ(x(4), 0.0);
    ASSERT_EQ(x(5), 0.0);
  }
}

TEST(UnicycleTest, DampingDecaysSpeedExponentially) {
  const UnicycleParameters p;
  const double dt = 0.1;
  const Unicycle unicycle(p, dt, 10);
  Eigen::VectorXd x = State(0.0, 0.0, 0.0, 1.2, 0.0, 0.0);
  for (int k = 1; k <= 30; ++k) {
    x = unicycle.Step(x, Eigen::Vector2d::Zero());
    ASSERT_NEAR(x(3), 1.2 * std::exp(-p.forward_damping / p.mass_kg * k * dt), 1e-8);
  }
}

TEST(UnicycleTest, OppositeForcesTurnInPlaceWithClosedFormYawRate) {
  // tau = half_track (F_r - F_l); r(t) = tau / b_r (1 - exp(-b_r t / I)); v = w = 0.
  const UnicycleParameters p;
  const double dt = 0.1;
  const Unicycle unicycle(p, dt, 10);
  Eigen::VectorXd x = State(0.5, 0.5, 0.0, 0, 0, 0);
  const Eigen::VectorXd u = Eigen::Vector2d(-0.4, 0.4);
  const double torque = p.half_track_m * 0.8;
  for (int k = 1; k <= 20; ++k) {
    x = unicycle.Step(x, u);
    const double r =
        torque / p.yaw_damping * (1 - std::exp(-p.yaw_damping / p.yaw_inertia * k * dt));
    ASSERT_NEAR(x(5), r, 1e-7);
    ASSERT_EQ(x(0), 0.5);
    ASSERT_EQ(x(3), 0.0);
  }
}

TEST(UnicycleTest, UnforcedKineticEnergyNeverIncreasesWhileTurningAndSlipping) {
  const Unicycle unicycle(UnicycleParameters{}, 0.1, 10);
  Eigen::VectorXd x = State(0.0, 0.0, 0.3, 1.5, -0.3, 2.0);
  double energy = unicycle.KineticEnergy(x);
  for (int k = 0; k < 300; ++k) {
    x = unicycle.Step(x, Eigen::Vector2d::Zero());
    const double next = unicycle.KineticEnergy(x);
    ASSERT_LE(next, energy + 1e-12) << "step " << k;
    energy = next;
  }
  EXPECT_LT(energy, 1e-6);
}

TEST(UnicycleTest, TurningAtSpeedMakesItSlipOutwards) {
  // Turning left (r > 0) at forward speed v > 0: w' = -b_w w / m - v r < 0.
  const Unicycle unicycle(UnicycleParameters{}, 0.1, 10);
  const Eigen::VectorXd next =
      unicycle.Step(State(0, 0, 0, 1.0, 0.0, 1.0), Eigen::Vector2d::Zero());
  EXPECT_LT(next(4), -1e-3);
}

TEST(UnicycleTest, Rk4ErrorShrinksSixteenfoldPerHalving) {
  const UnicycleParameters p;
  const Eigen::VectorXd x0 = State(0.0, 0.0, 0.5, 1.0, 0.2, 1.5);
  const Eigen::VectorXd u = Eigen::Vector2d(0.8, -0.3);
  const Eigen::VectorXd reference = Unicycle(p, 1.0, 4096).Step(x0, u);
  const double e1 = (Unicycle(p, 1.0, 16).Step(x0, u) - reference).norm();
  const double e2 = (Unicycle(p, 1.0, 32).Step(x0, u) - reference).norm();
  ASSERT_GT(e2, 0.0);
  EXPECT_NEAR(e1 / e2, 16.0, 3.0);
}

}  // namespace
}  // namespace excite::sim
