#include "server/gp/gp_model.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <random>
#include <string>

#include "server/gp/hyperparameters.h"
#include "server/gp/kernel.h"
#include "tests/gp/reference_gp.h"

namespace excite::gp {
namespace {

using testing::Data;
using testing::ExpectJacobiansMatchFiniteDifferences;
using testing::MakeData;
using testing::MakeHyperparameters;
using testing::ReferenceGp;
using testing::RelErr;

TEST(KernelTest, MatricesMatchScalarFormula) {
  const Data a = MakeData(7, 3, 1);
  const Data b = MakeData(5, 3, 2);
  const Hyperparameters h = MakeHyperparameters(3);
  const ReferenceGp ref(a.x, a.y, h);
  const Eigen::MatrixXd sa = ScaleInputs(a.x, h.lengthscales);
  const Eigen::MatrixXd sb = ScaleInputs(b.x, h.lengthscales);
  const Eigen::MatrixXd kc = CrossCovariance(sa, sb, h.signal_variance);
  const Eigen::MatrixXd ks = Covariance(sa, h.signal_variance);
  for (int i = 0; i < 7; ++i) {
    for (int j = 0; j < 5; ++j) {
      EXPECT_LT(RelErr(kc(i, j), ref.Kernel(a.x.row(i), b.x.row(j))), 1e-12);
    }
    for (int j = 0; j < 7; ++j) {
      EXPECT_LT(RelErr(ks(i, j), ref.Kernel(a.x.row(i), a.x.row(j))), 1e-12);
      EXPECT_EQ(ks(i, j), ks(j, i));
    }
  }
  // LogLengthscaleGradient against the double loop it replaces.
  Eigen::MatrixXd m = Eigen::MatrixXd::Random(7, 7);
  m = (m + m.transpose()).eval();
  const Eigen::VectorXd g = LogLengthscaleGradient(m, sa);
  for (int l = 0; l < 3; ++l) {
    double expected = 0.0;
    for (int i = 0; i < 7; ++i) {
      for (int j = 0; j < 7; ++j)
        expected += 0.5 * m(i, j) * std::pow(sa(i, l) - sa(j, l), 2);
    }
    EXPECT_LT(RelErr(g(l), expected), 1e-10);
  }
}

TEST(GpModelTest, PosteriorAndLmlMatchReference) {
  for (int d : {1, 3, 5}) {
    const Data data = MakeData(40, d, 10 + d);
    const Hyperparameters h = MakeHyperparameters(d);
    GpModel gp;
    ASSERT_TRUE(gp.Reset(data.x, data.y, h).ok());
    EXPECT_EQ(gp.jitter(), 0.0);
    const ReferenceGp ref(data.x, data.y, h);
    const Data test = MakeData(12, d, 99);
    Eigen::VectorXd mean, var;
    gp.Predict(test.x, &mean, &var, nullptr, nullptr);
    for (int i = 0; i < 12; ++i) {
      EXPECT_LT(RelErr(mean(i), ref.Mean(test.x.row(i))), 1e-8) << d << " " << i;
      EXPECT_LT(RelErr(var(i), ref.Variance(test.x.row(i))), 1e-8) << d << " " << i;
    }
    EXPECT_LT(RelErr(gp.log_marginal_likelihood(), ref.LogMarginalLikelihood()), 1e-8);
  }
}

TEST(GpModelTest, RowAppendEqualsRefactorisation) {
  const Data data = MakeData(60, 3, 3);
  const Hyperparameters h = MakeHyperparameters(3);
  GpModel appended;
  ASSERT_TRUE(appended.Reset(data.x.topRows(5), data.y.head(5), h).ok());
  for (int i = 5; i < 60; ++i) {  // crosses the initial capacity (16) several times
    ASSERT_TRUE(appended.AddSample(data.x.row(i).transpose(), data.y(i)).ok());
  }
  GpModel full;
  ASSERT_TRUE(full.Reset(data.x, data.y, h).ok());
  ASSERT_EQ(appended.size(), 60);
  EXPECT_LT((appended.cholesky() - full.cholesky()).cwiseAbs().maxCoeff(), 1e-10);
  EXPECT_LT((appended.alpha() - full.alpha()).cwiseAbs().maxCoeff(),
            1e-10 * full.alpha().cwiseAbs().maxCoeff());
  EXPECT_NEAR(appended.log_marginal_likelihood(), full.log_marginal_likelihood(), 1e-9);
  EXPECT_LT(
      (appended.LogMarginalLikelihoodGradient() - full.LogMarginalLikelihoodGradient())
          .cwiseAbs()
          .maxCoeff(),
      1e-8);
  const Data test = MakeData(8, 3, 7);
  Eigen::VectorXd m1, v1, m2, v2;
  appended.Predict(test.x, &m1, &v1, nullptr, nullptr);
  full.Predict(test.x, &m2, &v2, nullptr, nullptr);
  EXPECT_LT((m1 - m2).cwiseAbs().maxCoeff(), 1e-10);
  EXPECT_LT((v1 - v2).cwiseAbs().maxCoeff(), 1e-10);
  // Appending to an empty model works too.
  GpModel empty;
  ASSERT_TRUE(empty.Reset(Eigen::MatrixXd(0, 3), Eigen::VectorXd(0), h).ok());
  for (int i = 0; i < 60; ++i) {
    ASSERT_TRUE(empty.AddSample(data.x.row(i).transpose(), data.y(i)).ok());
  }
  EXPECT_LT((empty.cholesky() - full.cholesky()).cwiseAbs().maxCoeff(), 1e-10);
}

TEST(GpModelTest, LmlGradientMatchesFiniteDifferences) {
  const int d = 3;
  const Data data = MakeData(50, d, 4);
  const Hyperparameters h = MakeHyperparameters(d);
  GpModel gp;
  ASSERT_TRUE(gp.Reset(data.x, data.y, h).ok());
  const Eigen::VectorXd grad = gp.LogMarginalLikelihoodGradient();
  ASSERT_EQ(grad.size(), d + 2);
  auto lml_at = [&](int p, double step) {
    Hyperparameters hp = h;
    if (p == 0) hp.signal_variance *= std::exp(step);
    if (p >= 1 && p <= d) hp.lengthscales(p - 1) *= std::exp(step);
    if (p == d + 1) hp.noise_variance *= std::exp(step);
    GpModel other;
    EXPECT_TRUE(other.Reset(data.x, data.y, hp).ok());
    return other.log_marginal_likelihood();
  };
  const double eps = 1e-5;
  for (int p = 0; p < d + 2; ++p) {
    const double fd = (lml_at(p, eps) - lml_at(p, -eps)) / (2.0 * eps);
    EXPECT_LT(RelErr(grad(p), fd, 1e-3), 1e-6)
        << "parameter " << p << ": " << grad(p) << " vs " << fd;
  }
}

TEST(GpModelTest, PredictJacobiansMatchFiniteDifferences) {
  const int d = 4;
  const Data data = MakeData(30, d, 5);
  GpModel gp;
  ASSERT_TRUE(gp.Reset(data.x, data.y, MakeHyperparameters(d)).ok());
  ExpectJacobiansMatchFiniteDifferences(gp, MakeData(6, d, 6).x);
}

TEST(GpModelTest, IllConditionedDataStaysFinite) {
  // 3 distinct points repeated 30 times each, noise 1e-12.
  const Data base = MakeData(3, 2, 8, 0.0);
  Eigen::MatrixXd x(90, 2);
  Eigen::VectorXd y(90);
  for (int i = 0; i < 90; ++i) {
    x.row(i) = base.x.row(i % 3);
    y(i) = base.y(i % 3) + 1e-3 * (i % 7);  // inconsistent duplicates
  }
  Hyperparameters h = MakeHyperparameters(2);
  h.noise_variance = 1e-12;
  GpModel gp;
  ASSERT_TRUE(gp.Reset(x, y, h).ok());
  for (int i = 0; i < 20; ++i) {
    ASSERT_TRUE(gp.AddSample(base.x.row(i % 3).transpose(), base.y(i % 3)).ok());
  }
  const Data test = MakeData(10, 2, 9);
  Eigen::MatrixXd xs(13, 2);
  xs << test.x, base.x;
  Eigen::VectorXd mean, var;
  Eigen::MatrixXd dmean, dvar;
  gp.Predict(xs, &mean, &var, &dmean, &dvar);
  EXPECT_TRUE(mean.allFinite());
  EXPECT_TRUE(var.allFinite());
  EXPECT_TRUE((var.array() >= 0.0).all());
  EXPECT_TRUE(dmean.allFinite());
  EXPECT_TRUE(dvar.allFinite());
  EXPECT_TRUE(std::isfinite(gp.log_marginal_likelihood()));
  EXPECT_TRUE(gp.LogMarginalLikelihoodGradient().allFinite());
  RecordProperty("jitter", std::to_string(gp.jitter()));
}

TEST(GpModelTest, RejectsInvalidInput) {
  const Data data = MakeData(10, 2, 10);
  GpModel gp;
  Hyperparameters h = MakeHyperparameters(2);
  EXPECT_EQ(gp.Reset(data.x, data.y.head(9), h).code(),
            absl::StatusCode::kInvalidArgument);
  Hyperparameters bad = h;
  bad.lengthscales(1) = -1.0;
  EXPECT_EQ(gp.Reset(data.x, data.y, bad).code(), absl::StatusCode::kInvalidArgument);
  ASSERT_TRUE(gp.Reset(data.x, data.y, h).ok());
  EXPECT_EQ(gp.AddSample(Eigen::VectorXd::Zero(3), 0.0).code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(gp.AddSample(Eigen::VectorXd::Constant(2, NAN), 0.0).code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(gp.size(), 10);
}

}  // namespace
}  // namespace excite::gp
