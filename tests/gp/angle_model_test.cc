// Angles on the circle: InputFeatures' chain rule, and a DynamicsModel with
// angle_dims against finite differences and against turned copies of a state.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <random>
#include <vector>

#include "common/angles.h"
#include "server/gp/dynamics_model.h"
#include "server/gp/input_features.h"
#include "tests/gp/pendulum_samples.h"

namespace excite::gp {
namespace {

constexpr double kNoiseVar = 1e-3;

using testing::PendulumTransitions;
using testing::Transitions;
using testing::Z;

// States with angles in [angle_lo, angle_hi] (pendulum_samples.h).
Transitions MakeTransitions(int n, uint64_t seed, double angle_lo, double angle_hi) {
  return PendulumTransitions(n, seed, kNoiseVar, angle_lo, angle_hi);
}

DynamicsModelOptions AngleOptions() {
  DynamicsModelOptions o;
  o.state_dim = 2;
  o.input_dim = 1;
  o.angle_dims = {0};
  o.measurement_noise_variance = kNoiseVar;
  o.input_center = Eigen::Vector3d(0.0, 0.0, 0.0);
  o.input_half_width = Eigen::Vector3d(M_PI, 6.0, 2.0);
  return o;
}

// Four lengthscales: sin, cos of the angle, the rate, the torque.
std::vector<Hyperparameters> FixedHyperparameters() {
  Hyperparameters a, b;
  a.signal_variance = 0.5;
  a.lengthscales = Eigen::Vector4d(1.2, 0.9, 4.0, 3.0);
  a.noise_variance = 2e-3;
  b.signal_variance = 2.0;
  b.lengthscales = Eigen::Vector4d(0.8, 1.5, 6.0, 2.5);
  b.noise_variance = 3e-3;
  return {a, b};
}

DynamicsModel FittedModel(bool fit) {
  DynamicsModelOptions o = AngleOptions();
  o.fit_kernel = fit;
  if (!fit) o.fixed = FixedHyperparameters();
  absl::StatusOr<DynamicsModel> model = DynamicsModel::Create(o);
  EXPECT_TRUE(model.ok()) << model.status();
  const Transitions d = MakeTransitions(80, 3, -M_PI, M_PI);
  EXPECT_TRUE(model->AddSamples(d.x, d.u, d.next).ok());
  EXPECT_TRUE(model->Refit().ok());
  return std::move(*model);
}

TEST(WrapAngleTest, MapsOntoMinusPiExclusivePiInclusive) {
  EXPECT_DOUBLE_EQ(WrapAngle(0.25), 0.25);
  EXPECT_DOUBLE_EQ(WrapAngle(kPi), kPi);
  EXPECT_DOUBLE_EQ(WrapAngle(-kPi), kPi);
  EXPECT_NEAR(WrapAngle(3 * kPi), kPi, 1e-12);
  EXPECT_NEAR(WrapAngle(2 * kPi + 0.1), 0.1, 1e-12);
  EXPECT_NEAR(WrapAngle(-2 * kPi - 0.1), -0.1, 1e-12);
  EXPECT_NEAR(WrapAngle(-2 * kPi + 0.1), 0.1, 1e-12);
  for (double a = -40.0; a < 40.0; a += 0.37) {
    const double w = WrapAngle(a);
    EXPECT_GT(w, -kPi);
    EXPECT_LE(w, kPi);
    EXPECT_NEAR(std::remainder(a - w, 2 * kPi), 0.0, 1e-12) << a;
  }
}

TEST(InputFeaturesTest, AnglesBecomeSineAndCosineInPlace) {
  const InputFeatures features(4, {2, 0});
  EXPECT_EQ(features.feature_dim(), 6);
  EXPECT_TRUE(features.is_angle(0));
  EXPECT_FALSE(features.is_angle(1));
  Eigen::MatrixXd z(1, 4);
  z << 0.3, -1.5, 2.0, 7.0;
  Eigen::MatrixXd expected(1, 6);
  expected << std::sin(0.3), std::cos(0.3), -1.5, std::sin(2.0), std::cos(2.0), 7.0;
  EXPECT_TRUE(features.Map(z).isApprox(expected, 1e-15));
  const Eigen::VectorXd center = features.MapCenter(Eigen::Vector4d(1, 2, 3, 4));
  const Eigen::VectorXd width = features.MapHalfWidth(Eigen::Vector4d(5, 6, 7, 8));
  EXPECT_EQ(center, (Eigen::VectorXd(6) << 0, 0, 2, 0, 0, 4).finished());
  EXPECT_EQ(width, (Eigen::VectorXd(6) << 1, 1, 6, 1, 1, 8).finished());
}

// The chain rule against central differences of a linear functional of the
// features (error O(eps^2) ~ 1e-12 relative).
TEST(InputFeaturesTest, PullBackMatchesFiniteDifferences) {
  const InputFeatures features(4, {0, 2});
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-4.0, 4.0);
  Eigen::MatrixXd weights(3, 6);
  for (Eigen::Index k = 0; k < weights.size(); ++k) weights(k) = u(rng);
  Eigen::RowVectorXd z(4);
  for (int i = 0; i < 4; ++i) z(i) = u(rng);
  const Eigen::MatrixXd analytic = features.PullBack(weights, z);
  const double eps = 1e-6;
  for (int i = 0; i < 4; ++i) {
    Eigen::RowVectorXd plus = z, minus = z;
    plus(i) += eps;
    minus(i) -= eps;
    const Eigen::VectorXd fd =
        weights * (features.Map(plus) - features.Map(minus)).transpose() / (2 * eps);
    EXPECT_LT((analytic.col(i) - fd).cwiseAbs().maxCoeff(), 1e-8) << i;
  }
}

// A state and the same state turned by 2 pi k predict the same: the variance
// and the rate's mean exactly (to round-off), the angle's mean shifted by 2 pi k.
TEST(AngleModelTest, TurnedStatesPredictTheSame) {
  for (bool fit : {false, true}) {
    SCOPED_TRACE(fit ? "fitted" : "fixed");
    DynamicsModel model = FittedModel(fit);
    const Eigen::MatrixXd z = Z(MakeTransitions(20, 4, -M_PI, M_PI));
    Eigen::MatrixXd mean, var;
    model.Predict(z, &mean, &var, nullptr, nullptr);
    for (int k : {1, -3, 7}) {
      Eigen::MatrixXd turned = z;
      turned.col(0).array() += 2 * kPi * k;
      Eigen::MatrixXd mean_k, var_k;
      model.Predict(turned, &mean_k, &var_k, nullptr, nullptr);
      EXPECT_LT((var_k - var).cwiseAbs().maxCoeff(), 1e-9 * var.maxCoeff()) << k;
      EXPECT_LT((mean_k.col(1) - mean.col(1)).cwiseAbs().maxCoeff(), 1e-9) << k;
      EXPECT_LT((mean_k.col(0) - mean.col(0) - Eigen::VectorXd::Constant(20, 2 * kPi * k))
                    .cwiseAbs()
                    .maxCoeff(),
                1e-9)
          << k;
    }
  }
}

// Mean and variance Jacobians w.r.t. z (through sin and cos of the angle) against
// fourth-order central differences, tolerances as in dynamics_model_test.
TEST(AngleModelTest, JacobiansMatchFiniteDifferences) {
  for (bool fit : {false, true}) {
    SCOPED_TRACE(fit ? "fitted" : "fixed");
    DynamicsModel model = FittedModel(fit);
    const double var_tol = fit ? 1e-4 : 1e-6;
    const double mean_tol = fit ? 1e-5 : 1e-6;
    Eigen::MatrixXd z = Z(MakeTransitions(5, 6, -M_PI, M_PI));
    z(4, 0) += 4 * kPi;  // a turned state too
    Eigen::MatrixXd mean, var;
    std::vector<Eigen::MatrixXd> dmean, dvar;
    model.Predict(z, &mean, &var, &dmean, &dvar);
    ASSERT_EQ(dmean.size(), 5u);
    ASSERT_EQ(dmean[0].cols(), 3);
    const double eps = 1e-3;
    for (int l = 0; l < 3; ++l) {
      Eigen::MatrixXd fm[4], fv[4];
      const double steps[4] = {-2 * eps, -eps, eps, 2 * eps};
      for (int k = 0; k < 4; ++k) {
        Eigen::MatrixXd zk = z;
        zk.col(l).array() += steps[k];
        model.Predict(zk, &fm[k], &fv[k], nullptr, nullptr);
      }
      const Eigen::MatrixXd fdm = (fm[0] - 8 * fm[1] + 8 * fm[2] - fm[3]) / (12 * eps);
      const Eigen::MatrixXd fdv = (fv[0] - 8 * fv[1] + 8 * fv[2] - fv[3]) / (12 * eps);
      for (int i = 0; i < 5; ++i) {
        for (int j = 0; j < 2; ++j) {
          const double scale_m = std::max(1e-2, std::abs(fdm(i, j)));
          const double scale_v = std::max(1e-2 * var(i, j), std::abs(fdv(i, j)));
          EXPECT_LT(std::abs(dmean[i](j, l) - fdm(i, j)) / scale_m, mean_tol)
              << i << j << l << " " << dmean[i](j, l) << " vs " << fdm(i, j);
          EXPECT_LT(std::abs(dvar[i](j, l) - fdv(i, j)) / scale_v, var_tol)
              << i << j << l << " " << dvar[i](j, l) << " vs " << fdv(i, j);
        }
      }
    }
  }
}

// d/da of sum_j sum_ik W_j(i, k) cov_j(a_i, b_k) w.r.t. the points of a (their
// angles through sin and cos) against central differences.
TEST(AngleModelTest, CovarianceGradientMatchesFiniteDifferences) {
  DynamicsModel model = FittedModel(/*fit=*/false);
  const Eigen::MatrixXd a = Z(MakeTransitions(4, 7, -3 * M_PI, 3 * M_PI));
  const Eigen::MatrixXd b = Z(MakeTransitions(6, 8, -M_PI, M_PI));
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Eigen::MatrixXd> weights(2, Eigen::MatrixXd(4, 6));
  for (Eigen::MatrixXd& w : weights) {
    for (Eigen::Index k = 0; k < w.size(); ++k) w(k) = u(rng);
  }
  auto objective = [&](const Eigen::MatrixXd& points) {
    const auto pa = model.PreparePoints(points);
    const auto pb = model.PreparePoints(b);
    const std::vector<Eigen::MatrixXd> cov = model.PosteriorCovariance(*pa, *pb);
    return (weights[0].cwiseProduct(cov[0]) + weights[1].cwiseProduct(cov[1])).sum();
  };
  const auto pa = model.PreparePoints(a);
  const auto pb = model.PreparePoints(b);
  ASSERT_NE(pa, nullptr);
  const Eigen::MatrixXd grad =
      model.PosteriorCovarianceGradient(*pa, {{pb.get(), &weights}});
  ASSERT_EQ(grad.rows(), 4);
  ASSERT_EQ(grad.cols(), 3);
  const double eps = 1e-5;
  for (int i = 0; i < 4; ++i) {
    for (int l = 0; l < 3; ++l) {
      Eigen::MatrixXd plus = a, minus = a;
      plus(i, l) += eps;
      minus(i, l) -= eps;
      const double fd = (objective(plus) - objective(minus)) / (2 * eps);
      EXPECT_NEAR(grad(i, l), fd, 1e-7 * std::max(1.0, std::abs(fd))) << i << l;
    }
  }
}

// A step across +-pi is a small step: its wrapped difference is the target, so
// the prior mean of the angle's output is the small step, not nearly -2 pi.
TEST(AngleModelTest, DeltaTargetsOfAnglesAreWrapped) {
  absl::StatusOr<DynamicsModel> model = DynamicsModel::Create(AngleOptions());
  ASSERT_TRUE(model.ok());
  Eigen::MatrixXd x(2, 2), u(2, 1), next(2, 2);
  x << kPi - 0.05, 1.0, -kPi + 0.02, -1.0;
  u << 0.0, 0.0;
  next << -kPi + 0.05, 1.0, kPi - 0.02, -1.0;  // +0.1 and -0.04 the short way
  ASSERT_TRUE(model->AddSamples(x, u, next).ok());
  EXPECT_NEAR(model->prior_means()(0), 0.03, 1e-12);
  EXPECT_EQ(model->kernel_inputs(), 4);
}

// Trained on one turn, the angle model predicts the next turns as well; without
// angle_dims the GP has never seen those angles and falls back to its prior.
TEST(AngleModelTest, LearnsEveryTurnFromOne) {
  DynamicsModel angles = FittedModel(/*fit=*/true);
  DynamicsModelOptions o = AngleOptions();
  o.angle_dims.clear();
  absl::StatusOr<DynamicsModel> plain = DynamicsModel::Create(o);
  ASSERT_TRUE(plain.ok());
  const Transitions d = MakeTransitions(80, 3, -M_PI, M_PI);
  ASSERT_TRUE(plain->AddSamples(d.x, d.u, d.next).ok());
  ASSERT_TRUE(plain->Refit().ok());
  const Transitions test = MakeTransitions(200, 11, 3 * M_PI, 5 * M_PI);
  auto rmse = [&](const DynamicsModel& model) {
    Eigen::MatrixXd mean;
    model.Predict(Z(test), &mean, nullptr, nullptr, nullptr);
    return std::sqrt((mean - test.next).squaredNorm() / test.next.size());
  };
  const double with_angles = rmse(angles);
  const double without = rmse(*plain);
  EXPECT_LT(with_angles, 0.1);
  EXPECT_GT(without, 5 * with_angles) << with_angles;
}

TEST(AngleModelTest, RefusesWhatItCannotModel) {
  DynamicsModelOptions o = AngleOptions();
  o.target = Target::kNext;
  EXPECT_EQ(DynamicsModel::Create(o).status().code(), absl::StatusCode::kInvalidArgument);
  o = AngleOptions();
  o.angle_dims = {2};  // an input
  EXPECT_EQ(DynamicsModel::Create(o).status().code(), absl::StatusCode::kInvalidArgument);
  o.angle_dims = {0, 0};
  EXPECT_EQ(DynamicsModel::Create(o).status().code(), absl::StatusCode::kInvalidArgument);
  o = AngleOptions();
  o.fit_kernel = false;
  o.fixed = FixedHyperparameters();
  o.fixed[1].lengthscales = Eigen::Vector3d(1.0, 1.0, 1.0);  // z_dim, not kernel_inputs
  EXPECT_EQ(DynamicsModel::Create(o).status().code(), absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace excite::gp
