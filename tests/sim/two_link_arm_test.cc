#include "sim/plants/two_link_arm.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>

namespace excite::sim {
namespace {

const Eigen::VectorXd kNoTorque = Eigen::VectorXd::Zero(2);

// Centres of mass of the two uniform links, from the kinematics alone (q1 from the
// downward vertical, q2 relative to link 1; x right, y up).
Eigen::Vector2d Com1(const TwoLinkArmParameters& p, const Eigen::Vector2d& q) {
  return 0.5 * p.length1_m * Eigen::Vector2d(std::sin(q(0)), -std::cos(q(0)));
}
Eigen::Vector2d Com2(const TwoLinkArmParameters& p, const Eigen::Vector2d& q) {
  return p.length1_m * Eigen::Vector2d(std::sin(q(0)), -std::cos(q(0))) +
         0.5 * p.length2_m *
             Eigen::Vector2d(std::sin(q(0) + q(1)), -std::cos(q(0) + q(1)));
}

// Kinetic energy from the links' velocities (central differences of the kinematics)
// and their rotations: an independent reference for q'^T M(q) q' / 2.
double KineticEnergyFromKinematics(const TwoLinkArmParameters& p,
                                   const Eigen::Vector2d& q,
                                   const Eigen::Vector2d& q_dot) {
  const double h = 1e-6;
  const Eigen::Vector2d v1 = (Com1(p, q + h * q_dot) - Com1(p, q - h * q_dot)) / (2 * h);
  const Eigen::Vector2d v2 = (Com2(p, q + h * q_dot) - Com2(p, q - h * q_dot)) / (2 * h);
  const double i1 = p.mass1_kg * p.length1_m * p.length1_m / 12.0;
  const double i2 = p.mass2_kg * p.length2_m * p.length2_m / 12.0;
  return 0.5 * p.mass1_kg * v1.squaredNorm() + 0.5 * p.mass2_kg * v2.squaredNorm() +
         0.5 * i1 * q_dot(0) * q_dot(0) + 0.5 * i2 * std::pow(q_dot(0) + q_dot(1), 2);
}

double PotentialFromKinematics(const TwoLinkArmParameters& p, const Eigen::Vector2d& q) {
  return p.gravity * (p.mass1_kg * Com1(p, q)(1) + p.mass2_kg * Com2(p, q)(1));
}

TwoLinkArmParameters Asymmetric() {
  TwoLinkArmParameters p;
  p.mass1_kg = 1.3;
  p.mass2_kg = 0.7;
  p.length1_m = 0.9;
  p.length2_m = 1.2;
  p.damping1 = 0.4;
  p.damping2 = 0.2;
  return p;
}

TEST(TwoLinkArmTest, Dimensions) {
  const TwoLinkArm arm(TwoLinkArmParameters{}, 0.1, 20);
  EXPECT_EQ(arm.name(), "two_link");
  EXPECT_EQ(arm.state_dim(), 4);
  EXPECT_EQ(arm.input_dim(), 2);
}

TEST(TwoLinkArmTest, HangingEquilibriumIsFixedPoint) {
  const TwoLinkArm arm(Asymmetric(), 0.1, 20);
  const Eigen::VectorXd next = arm.Step(Eigen::Vector4d::Zero(), kNoTorque);
  EXPECT_EQ(next.norm(), 0.0);
}

TEST(TwoLinkArmTest, MassMatrixIsSymmetricPositiveDefiniteAndMatchesKinematics) {
  const TwoLinkArmParameters p = Asymmetric();
  const TwoLinkArm arm(p, 0.1, 20);
  for (double q2 = -M_PI; q2 <= M_PI; q2 += 0.3) {
    const Eigen::Matrix2d m = arm.MassMatrix(q2);
    EXPECT_EQ(m(0, 1), m(1, 0));
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(m);
    EXPECT_GT(eigen.eigenvalues().minCoeff(), 1e-3) << "q2 = " << q2;
    for (const Eigen::Vector2d& q_dot :
         {Eigen::Vector2d(1.0, 0.0), Eigen::Vector2d(0.0, 1.0),
          Eigen::Vector2d(-0.7, 2.1)}) {
      const Eigen::Vector2d q(0.4, q2);
      EXPECT_NEAR(0.5 * q_dot.dot(m * q_dot), KineticEnergyFromKinematics(p, q, q_dot),
                  1e-7);
    }
  }
}

TEST(TwoLinkArmTest, GravityTorquesAreTheGradientOfThePotential) {
  const TwoLinkArmParameters p = Asymmetric();
  const TwoLinkArm arm(p, 0.1, 20);
  const double h = 1e-6;
  for (const Eigen::Vector2d& q : {Eigen::Vector2d(0.3, -0.8), Eigen::Vector2d(2.0, 1.0),
                                   Eigen::Vector2d(-1.0, 3.0)}) {
    const Eigen::Vector2d g = arm.GravityTorques(q);
    for (int i = 0; i < 2; ++i) {
      const Eigen::Vector2d e = Eigen::Vector2d::Unit(i) * h;
      const double fd =
          (PotentialFromKinematics(p, q + e) - PotentialFromKinematics(p, q - e)) /
          (2 * h);
      EXPECT_NEAR(g(i), fd, 1e-6);
    }
  }
}

TEST(TwoLinkArmTest, UndampedUnforcedConservesEnergy) {
  // Energy is conserved only if C(q, q') is consistent with M(q) (M' - 2C skew).
  TwoLinkArmParameters p = Asymmetric();
  p.damping1 = 0.0;
  p.damping2 = 0.0;
  const TwoLinkArm arm(p, 0.01, 4);
  Eigen::VectorXd x = Eigen::Vector4d(1.5, -1.0, 2.0, -3.0);
  const double energy = arm.Energy(x);
  for (int k = 0; k < 1000; ++k) x = arm.Step(x, kNoTorque);  // 10 s of chaotic motion.
  EXPECT_NEAR(arm.Energy(x), energy, 1e-6 * energy);
}

TEST(TwoLinkArmTest, DampedUnforcedComesToRestAndEnergyNeverIncreases) {
  const TwoLinkArm arm(Asymmetric(), 0.1, 20);
  Eigen::VectorXd x = Eigen::Vector4d(2.0, -1.5, 1.0, 3.0);
  double energy = arm.Energy(x);
  for (int k = 0; k < 3000; ++k) {  // 300 s.
    x = arm.Step(x, kNoTorque);
    const double next_energy = arm.Energy(x);
    ASSERT_LE(next_energy, energy + 1e-12) << "step " << k;
    energy = next_energy;
  }
  // At rest hanging (angles modulo 2 pi).
  EXPECT_NEAR(std::remainder(x(0), 2 * M_PI), 0.0, 1e-6);
  EXPECT_NEAR(std::remainder(x(0) + x(1), 2 * M_PI), 0.0, 1e-6);
  EXPECT_NEAR(x(2), 0.0, 1e-6);
  EXPECT_NEAR(x(3), 0.0, 1e-6);
}

TEST(TwoLinkArmTest, ConstantTorquesSettleWhereGravityBalancesThem) {
  const TwoLinkArmParameters p = Asymmetric();
  const TwoLinkArm arm(p, 0.1, 20);
  const Eigen::Vector2d q_star(0.3, -0.2);
  const Eigen::VectorXd tau = arm.GravityTorques(q_star);
  Eigen::VectorXd x = Eigen::Vector4d::Zero();
  for (int k = 0; k < 2000; ++k) x = arm.Step(x, tau);
  EXPECT_NEAR(x(0), q_star(0), 1e-6);
  EXPECT_NEAR(x(1), q_star(1), 1e-6);
}

TEST(TwoLinkArmTest, Rk4ErrorShrinksSixteenfoldPerHalving) {
  const TwoLinkArmParameters p = Asymmetric();
  const Eigen::VectorXd x0 = Eigen::Vector4d(1.0, 0.5, -1.0, 2.0);
  const Eigen::VectorXd u = Eigen::Vector2d(1.0, -0.5);
  const Eigen::VectorXd reference = TwoLinkArm(p, 1.0, 4096).Step(x0, u);
  const double e1 = (TwoLinkArm(p, 1.0, 16).Step(x0, u) - reference).norm();
  const double e2 = (TwoLinkArm(p, 1.0, 32).Step(x0, u) - reference).norm();
  ASSERT_GT(e2, 0.0);
  EXPECT_NEAR(e1 / e2, 16.0, 3.0);
}

}  // namespace
}  // namespace excite::sim
