#include "server/plan/rollout.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>

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

}  // namespace
}  // namespace excite::plan
