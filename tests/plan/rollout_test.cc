#include "server/plan/rollout.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <iostream>
#include <random>

#include "tests/plan/pendulum_gp.h"

namespace excite::plan {
namespace {

using testing::FittedModel;

// The reference: one full one-point Predict per step, as RollOut did before it
// batched the variances.
TEST(RolloutTest, EqualsOnePointPredictionsStepByStep) {
  const gp::DynamicsModel model = FittedModel(200);
  const Eigen::Vector2d x0(0.4, -1.1);
  const Eigen::MatrixXd inputs = 3.0 * Eigen::MatrixXd::Random(15, 1);
  const Rollout r = RollOut(model, x0, inputs);
  ASSERT_TRUE(r.valid);
  ASSERT_EQ(r.variances.rows(), 15);
  Eigen::VectorXd x = x0;
  for (int i = 0; i < 15; ++i) {
    Eigen::MatrixXd z(1, 3), mean, variance;
    z << x.transpose(), inputs(i, 0);
    model.Predict(z, &mean, &variance, nullptr, nullptr);
    EXPECT_LT((r.states.row(i).transpose() - x).norm(), 1e-12) << i;
    EXPECT_LT((r.means.row(i) - mean.row(0)).norm(), 1e-12) << i;
    for (int j = 0; j < 2; ++j) {
      EXPECT_NEAR(r.variances(i, j), variance(0, j), 1e-10 * variance(0, j))
          << i << ", " << j;
    }
    x = mean.row(0).transpose();
  }
}

TEST(RolloutTest, MismatchedShapesAreInvalidAndNoInputsRollOutNothing) {
  const gp::DynamicsModel model = FittedModel(30);
  EXPECT_FALSE(
      RollOut(model, Eigen::Vector3d(0, 0, 0), Eigen::MatrixXd::Zero(4, 1)).valid);
  EXPECT_FALSE(RollOut(model, Eigen::Vector2d(0, 0), Eigen::MatrixXd::Zero(4, 2)).valid);
  const Rollout empty = RollOut(model, Eigen::Vector2d(0, 0), Eigen::MatrixXd(0, 1));
  EXPECT_EQ(empty.states.rows(), 0);
  EXPECT_EQ(empty.variances.rows(), 0);
}

// The linearised propagation against Monte Carlo through the same GP: 20000
// states drawn from N(x0, Sigma0), each stepped by a fresh draw from the GP's
// predictive distribution at its own (x, u) (the assumption the propagation
// makes), over 8 steps. Tolerances: the means agree within 4 standard errors
// plus 2 % of the spread, the standard deviations within 5 % (1.3 % measured; first-order
// error grows with the spread; the pendulum's mean is close to linear over
// these spreads), and the first step exactly (one linear map of a Gaussian
// plus independent noise).
TEST(RolloutTest, LinearisedPropagationMatchesMonteCarlo) {
  const gp::DynamicsModel model = FittedModel(150);
  const Eigen::Vector2d x0(0.3, -0.5);
  Eigen::Matrix2d cov0;
  cov0 << 4e-3, 1e-3, 1e-3, 9e-3;
  Eigen::MatrixXd inputs(8, 1);
  inputs << 1.0, 1.0, -0.5, -0.5, 2.0, 0.0, -1.0, 1.5;
  const PropagatedTrajectory p =
      PropagateLinearised(model, x0, cov0, inputs, Eigen::VectorXd());
  ASSERT_TRUE(p.valid);
  ASSERT_EQ(p.means.rows(), 9);
  EXPECT_LT((p.covariances[0] - cov0).norm(), 1e-15);

  const int n = 20000;
  std::mt19937_64 rng(11);
  std::normal_distribution<double> normal;
  const Eigen::LLT<Eigen::Matrix2d> chol(cov0);
  Eigen::MatrixXd x(n, 2);
  for (int i = 0; i < n; ++i) {
    x.row(i) =
        (x0 + chol.matrixL() * Eigen::Vector2d(normal(rng), normal(rng))).transpose();
  }
  double worst_sd = 0.0;  // largest |sd / mc_sd - 1| over steps 2..8, reported
  for (int k = 0; k < 8; ++k) {
    Eigen::MatrixXd z(n, 3), mean, variance;
    z << x, Eigen::VectorXd::Constant(n, inputs(k, 0));
    model.Predict(z, &mean, &variance, nullptr, nullptr);
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < 2; ++j) {
        x(i, j) = mean(i, j) + std::sqrt(std::max(0.0, variance(i, j))) * normal(rng);
      }
    }
    const Eigen::RowVector2d mc_mean = x.colwise().mean();
    const Eigen::MatrixXd centred = x.rowwise() - mc_mean;
    const Eigen::Matrix2d mc_cov = centred.transpose() * centred / (n - 1);
    const Eigen::Matrix2d& cov = p.covariances[static_cast<size_t>(k + 1)];
    for (int j = 0; j < 2; ++j) {
      const double sd = std::sqrt(cov(j, j)), mc_sd = std::sqrt(mc_cov(j, j));
      const double tolerance = k == 0 ? 0.03 : 0.05;  // step 1: sampling error only
      if (k > 0) worst_sd = std::max(worst_sd, std::abs(sd / mc_sd - 1));
      EXPECT_NEAR(sd, mc_sd, tolerance * mc_sd) << "step " << k + 1 << " dim " << j;
      EXPECT_NEAR(p.means(k + 1, j), mc_mean(j), 4 * mc_sd / std::sqrt(n) + 0.02 * mc_sd)
          << "step " << k + 1 << " dim " << j;
    }
  }
  std::cout << "linearised vs Monte Carlo: largest std deviation " << worst_sd << "\n";
  // Shapes that do not fit give an invalid trajectory, not a crash.
  EXPECT_FALSE(
      PropagateLinearised(model, Eigen::Vector3d::Zero(), cov0, inputs, Eigen::VectorXd())
          .valid);
}

}  // namespace
}  // namespace excite::plan
