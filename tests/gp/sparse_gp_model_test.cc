#include "server/gp/sparse_gp_model.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>

#include "server/gp/gp_model.h"
#include "server/gp/hyperparameters.h"
#include "tests/gp/reference_gp.h"

namespace excite::gp {
namespace {

using testing::Data;
using testing::ExpectJacobiansMatchFiniteDifferences;
using testing::MakeData;
using testing::MakeHyperparameters;
using testing::ReferenceGp;
using testing::RelErr;

SparseGpOptions Options(int max_inducing, double inducing_tolerance) {
  SparseGpOptions options;
  options.max_inducing = max_inducing;
  options.inducing_tolerance = inducing_tolerance;
  return options;
}

struct Prediction {
  Eigen::VectorXd mean, variance;
  Eigen::MatrixXd mean_jacobian, variance_jacobian;
};

template <typename Model>
Prediction PredictAll(const Model& model, const Eigen::MatrixXd& xs) {
  Prediction p;
  model.Predict(xs, &p.mean, &p.variance, &p.mean_jacobian, &p.variance_jacobian);
  return p;
}

TEST(SparseGpModelTest, EveryPointInducingIsTheExactGp) {
  for (int d : {2, 3}) {
    const Data data = MakeData(25, d, 30 + d);
    // Short lengthscales: no sample is explained by the others.
    Hyperparameters h = MakeHyperparameters(d);
    h.lengthscales *= 0.2;
    SparseGpModel sparse(Options(64, 1e-10));
    ASSERT_TRUE(sparse.Reset(data.x, data.y, h).ok());
    ASSERT_EQ(sparse.inducing_count(), 25);
    const ReferenceGp reference(data.x, data.y, h);
    GpModel exact;
    ASSERT_TRUE(exact.Reset(data.x, data.y, h).ok());
    const Data test = MakeData(8, d, 40 + d);
    const Prediction s = PredictAll(sparse, test.x);
    const Prediction e = PredictAll(exact, test.x);
    for (int i = 0; i < 8; ++i) {
      EXPECT_LT(RelErr(s.mean(i), reference.Mean(test.x.row(i)), 1e-3), 1e-7);
      EXPECT_LT(RelErr(s.variance(i), reference.Variance(test.x.row(i)), 1e-3), 1e-6);
    }
    EXPECT_LT((s.mean_jacobian - e.mean_jacobian).cwiseAbs().maxCoeff(), 1e-6);
    EXPECT_LT((s.variance_jacobian - e.variance_jacobian).cwiseAbs().maxCoeff(), 1e-6);
  }
}

TEST(SparseGpModelTest, JacobiansMatchFiniteDifferences) {
  const int d = 3;
  const Data data = MakeData(300, d, 5);
  SparseGpModel sparse(Options(40, 1e-3));
  ASSERT_TRUE(sparse.Reset(data.x, data.y, MakeHyperparameters(d)).ok());
  ASSERT_GT(sparse.inducing_count(), 5);
  ASSERT_LT(sparse.inducing_count(), 300);
  ExpectJacobiansMatchFiniteDifferences(sparse, MakeData(6, d, 6).x);
}

TEST(SparseGpModelTest, AddingSamplesOneByOneEqualsABatch) {
  const int d = 2;
  const Data data = MakeData(400, d, 7);
  const Hyperparameters h = MakeHyperparameters(d);
  const SparseGpOptions options = Options(30, 1e-4);
  SparseGpModel batch(options);
  ASSERT_TRUE(batch.Reset(data.x, data.y, h).ok());
  SparseGpModel online(options);
  ASSERT_TRUE(online.Reset(data.x.topRows(10), data.y.head(10), h).ok());
  for (int i = 10; i < 400; ++i) {
    ASSERT_TRUE(online.AddSample(data.x.row(i).transpose(), data.y(i)).ok());
  }
  // The cap is reached, and the same samples are chosen.
  ASSERT_EQ(batch.inducing_count(), 30);
  EXPECT_EQ(online.inducing_indices(), batch.inducing_indices());
  EXPECT_EQ(online.size(), 400);
  const Data test = MakeData(20, d, 8);
  const Prediction a = PredictAll(batch, test.x);
  const Prediction b = PredictAll(online, test.x);
  EXPECT_LT((a.mean - b.mean).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((a.variance - b.variance).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((a.mean_jacobian - b.mean_jacobian).cwiseAbs().maxCoeff(), 1e-8);
  EXPECT_LT((a.variance_jacobian - b.variance_jacobian).cwiseAbs().maxCoeff(), 1e-8);
}

TEST(SparseGpModelTest, ShiftTargetsEqualsResetOnShiftedTargets) {
  const Data data = MakeData(200, 2, 9);
  const Hyperparameters h = MakeHyperparameters(2);
  SparseGpModel shifted;
  ASSERT_TRUE(shifted.Reset(data.x, data.y, h).ok());
  shifted.ShiftTargets(0.7);
  SparseGpModel reset;
  ASSERT_TRUE(reset.Reset(data.x, (data.y.array() - 0.7).matrix(), h).ok());
  const Data test = MakeData(10, 2, 10);
  const Prediction a = PredictAll(shifted, test.x);
  const Prediction b = PredictAll(reset, test.x);
  EXPECT_LT((a.mean - b.mean).cwiseAbs().maxCoeff(), 1e-10);
  EXPECT_LT((shifted.targets() - reset.targets()).cwiseAbs().maxCoeff(), 1e-15);
}

TEST(SparseGpModelTest, CloseToTheExactGpWithFarFewerPoints) {
  // 2000 noisy samples of a smooth function: a few dozen inducing points carry
  // the posterior.
  const int d = 2;
  const Data data = MakeData(2000, d, 11);
  const Hyperparameters h = MakeHyperparameters(d);
  SparseGpModel sparse(Options(256, 0.1));
  ASSERT_TRUE(sparse.Reset(data.x, data.y, h).ok());
  EXPECT_LT(sparse.inducing_count(), 100);
  GpModel exact;
  ASSERT_TRUE(exact.Reset(data.x, data.y, h).ok());
  const Data test = MakeData(500, d, 12);
  Eigen::VectorXd sm, sv, em, ev;
  sparse.Predict(test.x, &sm, &sv, nullptr, nullptr);
  exact.Predict(test.x, &em, &ev, nullptr, nullptr);
  // Against the noise (std 0.22) and the prior (signal variance 1.3).
  EXPECT_LT((sm - em).cwiseAbs().maxCoeff(), 0.05 * std::sqrt(h.noise_variance));
  EXPECT_LT((sv - ev).cwiseAbs().maxCoeff(), 0.1 * h.noise_variance);
  // Far from the data both revert to the prior.
  Eigen::MatrixXd far = Eigen::MatrixXd::Constant(1, d, 9.0);
  sparse.Predict(far, &sm, &sv, nullptr, nullptr);
  EXPECT_NEAR(sm(0), 0.0, 1e-12);
  EXPECT_NEAR(sv(0), h.signal_variance, 1e-9);
}

TEST(SparseGpModelTest, BadInputIsRejectedAndChangesNothing) {
  const Data data = MakeData(20, 2, 13);
  const Hyperparameters h = MakeHyperparameters(2);
  SparseGpModel model;
  EXPECT_EQ(model.AddSample(Eigen::VectorXd::Zero(2), 0.0).code(),
            absl::StatusCode::kFailedPrecondition);
  Hyperparameters wrong = h;
  wrong.lengthscales = Eigen::VectorXd::Ones(3);
  EXPECT_EQ(model.Reset(data.x, data.y, wrong).code(),
            absl::StatusCode::kInvalidArgument);
  wrong = h;
  wrong.noise_variance = 0.0;
  EXPECT_EQ(model.Reset(data.x, data.y, wrong).code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(model.Reset(data.x, data.y.head(19), h).code(),
            absl::StatusCode::kInvalidArgument);
  SparseGpModel no_room(Options(0, 1e-3));
  EXPECT_EQ(no_room.Reset(data.x, data.y, h).code(), absl::StatusCode::kInvalidArgument);

  ASSERT_TRUE(model.Reset(data.x, data.y, h).ok());
  const Data test = MakeData(5, 2, 14);
  const Prediction before = PredictAll(model, test.x);
  EXPECT_EQ(model.AddSample(Eigen::VectorXd::Zero(3), 0.0).code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(model.AddSample(Eigen::VectorXd::Constant(2, NAN), 0.0).code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(model.AddSample(Eigen::VectorXd::Zero(2), INFINITY).code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(model.size(), 20);
  const Prediction after = PredictAll(model, test.x);
  EXPECT_EQ(before.mean, after.mean);
  EXPECT_EQ(before.variance, after.variance);
}

}  // namespace
}  // namespace excite::gp
