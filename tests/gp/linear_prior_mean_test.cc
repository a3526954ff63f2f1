// PriorMean::kLinear: the least-squares affine mean against its closed form (normal
// equations) and a reference GP on the residuals, fixed between refits and rebuilt
// the same after a restart, exact and sparse, with angles, and its Jacobians.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <vector>

#include "common/angles.h"
#include "server/gp/dynamics_model.h"
#include "server/gp/hyperparameters.h"
#include "tests/gp/pendulum_samples.h"
#include "tests/gp/reference_gp.h"

namespace excite::gp {
namespace {

using testing::PendulumTransitions;
using testing::ReferenceGp;
using testing::RelErr;
using testing::Transitions;
using testing::Z;

constexpr double kNoiseVar = 1e-3;
const Eigen::Vector3d kCenter(0.2, -0.5, 0.1);
const Eigen::Vector3d kHalfWidth(3.0, 6.0, 2.0);

DynamicsModelOptions LinearOptions(Target target) {
  DynamicsModelOptions o;
  o.state_dim = 2;
  o.input_dim = 1;
  o.target = target;
  o.prior_mean = PriorMean::kLinear;
  o.measurement_noise_variance = kNoiseVar;
  o.input_center = kCenter;
  o.input_half_width = kHalfWidth;
  o.fit_kernel = false;
  o.fixed = testing::DataUnitHyperparameters();
  return o;
}

DynamicsModel Model(const DynamicsModelOptions& o) {
  absl::StatusOr<DynamicsModel> model = DynamicsModel::Create(o);
  EXPECT_TRUE(model.ok()) << model.status();
  return std::move(*model);
}

// Coefficients (intercept, then slopes on the normalised z) by the normal
// equations: an independent route to the least-squares fit.
Eigen::MatrixXd NormalEquations(const Eigen::MatrixXd& z, const Eigen::MatrixXd& y) {
  Eigen::MatrixXd design(z.rows(), z.cols() + 1);
  design << Eigen::VectorXd::Ones(z.rows()),
      (z.rowwise() - kCenter.transpose()) * kHalfWidth.cwiseInverse().asDiagonal();
  return (design.transpose() * design).ldlt().solve(design.transpose() * y);
}

// The fit, its report in data units, and the whole predictor: the linear mean plus a
// reference GP on the residuals; far from the data, the linear mean alone.
TEST(LinearPriorMeanTest, IsTheLeastSquaresFitUnderAReferenceGp) {
  for (Target target : {Target::kDelta, Target::kNext}) {
    SCOPED_TRACE(target == Target::kDelta ? "delta" : "next");
    const DynamicsModelOptions o = LinearOptions(target);
    DynamicsModel model = Model(o);
    const Transitions d = PendulumTransitions(60, 1, kNoiseVar);
    ASSERT_TRUE(model.AddSamples(d.x, d.u, d.next).ok());
    ASSERT_TRUE(model.Refit().ok());
    const Eigen::MatrixXd targets =
        target == Target::kDelta ? Eigen::MatrixXd(d.next - d.x) : d.next;
    const Eigen::MatrixXd c = NormalEquations(Z(d), targets);
    const Eigen::MatrixXd slopes = model.prior_mean_slopes();
    ASSERT_EQ(slopes.rows(), 2);
    ASSERT_EQ(slopes.cols(), 3);
    Eigen::MatrixXd far = Z(PendulumTransitions(4, 2, kNoiseVar));
    far.array() += 1e3;  // every kernel value underflows to 0
    Eigen::MatrixXd near_z = Z(PendulumTransitions(7, 3, kNoiseVar));
    Eigen::MatrixXd far_mean, near_mean, near_var;
    model.Predict(far, &far_mean, nullptr, nullptr, nullptr);
    model.Predict(near_z, &near_mean, &near_var, nullptr, nullptr);
    for (int j = 0; j < 2; ++j) {
      EXPECT_LT(RelErr(model.prior_means()(j), c(0, j)), 1e-9);
      for (int l = 0; l < 3; ++l) {
        EXPECT_LT(RelErr(slopes(j, l), c(l + 1, j) / kHalfWidth(l)), 1e-9) << l;
      }
      const auto linear = [&](const Eigen::RowVectorXd& z) {
        return model.prior_means()(j) + slopes.row(j).dot(z - kCenter.transpose());
      };
      for (int i = 0; i < far.rows(); ++i) {
        const double x = target == Target::kDelta ? far(i, j) : 0.0;
        EXPECT_LT(RelErr(far_mean(i, j), x + linear(far.row(i))), 1e-12);
      }
      Eigen::VectorXd residuals(d.x.rows());
      for (int i = 0; i < d.x.rows(); ++i)
        residuals(i) = targets(i, j) - linear(Z(d).row(i));
      const ReferenceGp ref(Z(d), residuals, o.fixed[j]);
      EXPECT_LT(RelErr(model.log_marginal_likelihoods()[j], ref.LogMarginalLikelihood()),
                1e-9);
      for (int i = 0; i < near_z.rows(); ++i) {
        const double x = target == Target::kDelta ? near_z(i, j) : 0.0;
        EXPECT_LT(
            RelErr(near_mean(i, j), x + linear(near_z.row(i)) + ref.Mean(near_z.row(i))),
            1e-9);
        EXPECT_LT(RelErr(near_var(i, j), ref.Variance(near_z.row(i))), 1e-9);
      }
    }
  }
}

// With at most 2 (inputs + 1) samples the fit would follow the noise: the mean is
// constant, the targets' mean.
TEST(LinearPriorMeanTest, IsConstantUntilThereAreEnoughSamples) {
  DynamicsModel model = Model(LinearOptions(Target::kDelta));
  const Transitions d = PendulumTransitions(8, 4, kNoiseVar);
  ASSERT_TRUE(model.AddSamples(d.x, d.u, d.next).ok());
  ASSERT_TRUE(model.Refit().ok());
  EXPECT_TRUE(model.prior_mean_slopes().isZero(0.0));
  const Eigen::VectorXd mean = (d.next - d.x).colwise().mean().transpose();
  EXPECT_LT((model.prior_means() - mean).cwiseAbs().maxCoeff(), 1e-15);
}

// Samples added after a refit leave the mean as it was; a model restored from the
// same data and the saved fit (SeedWarmStart + Rebuild) refits the mean on the
// samples of that fit and predicts the same. Exact and sparse (fitted: its
// hyperparameters come from the data too).
TEST(LinearPriorMeanTest, StaysBetweenRefitsAndRebuildsTheSame) {
  for (bool sparse : {false, true}) {
    SCOPED_TRACE(sparse ? "sparse" : "exact");
    DynamicsModelOptions o = LinearOptions(Target::kDelta);
    o.fit_kernel = sparse;
    if (sparse) {
      o.sparse_above = 20;
      o.sparse.max_inducing = 30;
    }
    DynamicsModel original = Model(o);
    const Transitions d = PendulumTransitions(56, 11, kNoiseVar);
    ASSERT_TRUE(
        original.AddSamples(d.x.topRows(50), d.u.topRows(50), d.next.topRows(50)).ok());
    ASSERT_TRUE(original.Refit().ok());
    EXPECT_EQ(original.sparse(), sparse);
    const Eigen::VectorXd intercept = original.prior_means();
    const Eigen::MatrixXd slopes = original.prior_mean_slopes();
    EXPECT_FALSE(slopes.isZero(0.0));
    ASSERT_TRUE(
        original.AddSamples(d.x.bottomRows(6), d.u.bottomRows(6), d.next.bottomRows(6))
            .ok());
    EXPECT_EQ(original.prior_means(), intercept);
    EXPECT_EQ(original.prior_mean_slopes(), slopes);

    DynamicsModel restored = Model(o);
    ASSERT_TRUE(restored.AddSamples(d.x, d.u, d.next).ok());
    ASSERT_TRUE(restored.SeedWarmStart(original.hyperparameters(), 50).ok());
    ASSERT_TRUE(restored.Rebuild().ok());
    EXPECT_LT((restored.prior_means() - intercept).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LT((restored.prior_mean_slopes() - slopes).cwiseAbs().maxCoeff(), 1e-12);
    const Eigen::MatrixXd zt = Z(PendulumTransitions(9, 12, kNoiseVar));
    Eigen::MatrixXd m1, v1, m2, v2;
    original.Predict(zt, &m1, &v1, nullptr, nullptr);
    restored.Predict(zt, &m2, &v2, nullptr, nullptr);
    EXPECT_LT((m1 - m2).cwiseAbs().maxCoeff(), 1e-9);
    EXPECT_LT((v1 - v2).cwiseAbs().maxCoeff(), 1e-9 * v1.cwiseAbs().maxCoeff());

    // A refit takes the new samples into the mean.
    ASSERT_TRUE(original.Refit().ok());
    EXPECT_GT((original.prior_mean_slopes() - slopes).cwiseAbs().maxCoeff(), 1e-9);
  }
}

// With an angle (sin, cos features): a state turned by 2 pi predicts the same, and
// the mean's Jacobian w.r.t. z, linear part included, matches fourth-order central
// differences.
TEST(LinearPriorMeanTest, AnglesTurnAndJacobiansMatchFiniteDifferences) {
  DynamicsModelOptions o = LinearOptions(Target::kDelta);
  o.angle_dims = {0};
  o.input_center = Eigen::Vector3d(0.0, 0.0, 0.0);
  o.input_half_width = Eigen::Vector3d(M_PI, 6.0, 2.0);
  for (Hyperparameters& h : o.fixed) {
    h.lengthscales = Eigen::Vector4d(1.2, 0.9, h.lengthscales(1), h.lengthscales(2));
  }
  DynamicsModel model = Model(o);
  const Transitions d = PendulumTransitions(80, 3, kNoiseVar, -M_PI, M_PI);
  ASSERT_TRUE(model.AddSamples(d.x, d.u, d.next).ok());
  ASSERT_TRUE(model.Refit().ok());
  ASSERT_EQ(model.prior_mean_slopes().cols(), 4);
  EXPECT_FALSE(model.prior_mean_slopes().isZero(0.0));
  Eigen::MatrixXd z = Z(PendulumTransitions(5, 6, kNoiseVar, -M_PI, M_PI));
  z(4, 0) += 4 * kPi;
  Eigen::MatrixXd mean, turned_mean;
  std::vector<Eigen::MatrixXd> dmean;
  model.Predict(z, &mean, nullptr, &dmean, nullptr);
  Eigen::MatrixXd turned = z;
  turned.col(0).array() -= 2 * kPi;
  model.Predict(turned, &turned_mean, nullptr, nullptr, nullptr);
  EXPECT_LT((turned_mean.col(1) - mean.col(1)).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((turned_mean.col(0).array() + 2 * kPi - mean.col(0).array()).abs().maxCoeff(),
            1e-9);
  const double eps = 1e-3;
  for (int l = 0; l < 3; ++l) {
    Eigen::MatrixXd f[4];
    const double steps[4] = {-2 * eps, -eps, eps, 2 * eps};
    for (int k = 0; k < 4; ++k) {
      Eigen::MatrixXd zk = z;
      zk.col(l).array() += steps[k];
      model.Predict(zk, &f[k], nullptr, nullptr, nullptr);
    }
    const Eigen::MatrixXd fd = (f[0] - 8 * f[1] + 8 * f[2] - f[3]) / (12 * eps);
    for (int i = 0; i < 5; ++i) {
      for (int j = 0; j < 2; ++j) {
        EXPECT_LT(RelErr(dmean[i](j, l), fd(i, j), 1e-2), 1e-6)
            << i << j << l << " " << dmean[i](j, l) << " vs " << fd(i, j);
      }
    }
  }
}

}  // namespace
}  // namespace excite::gp
