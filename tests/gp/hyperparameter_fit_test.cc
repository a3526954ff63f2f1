#include "server/gp/hyperparameter_fit.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <optional>
#include <random>

#include "server/gp/gp_model.h"
#include "server/gp/hyperparameters.h"
#include "tests/gp/reference_gp.h"

namespace excite::gp {
namespace {

// Draws y = f(x) + noise with f from a GP with hyperparameters `h` (sampled
// through an LLT of the reference kernel matrix, independent of GpModel).
void SampleFromGp(const Hyperparameters& h, int n, uint64_t seed, Eigen::MatrixXd* x,
                  Eigen::VectorXd* y) {
  const int d = static_cast<int>(h.lengthscales.size());
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> g(0.0, 1.0);
  x->resize(n, d);
  for (int i = 0; i < n; ++i) {
    for (int l = 0; l < d; ++l) (*x)(i, l) = u(rng);
  }
  Hyperparameters noiseless = h;
  noiseless.noise_variance = 1e-8;
  const testing::ReferenceGp ref(*x, Eigen::VectorXd::Zero(n), noiseless);
  Eigen::MatrixXd k(n, n);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) k(i, j) = ref.Kernel(x->row(i), x->row(j));
    k(i, i) += 1e-8;
  }
  const Eigen::MatrixXd l = k.llt().matrixL();
  Eigen::VectorXd w(n), e(n);
  for (int i = 0; i < n; ++i) w(i) = g(rng);
  for (int i = 0; i < n; ++i) e(i) = std::sqrt(h.noise_variance) * g(rng);
  *y = l * w + e;
}

Hyperparameters Truth() {
  Hyperparameters h;
  h.signal_variance = 1.0;
  h.lengthscales = Eigen::Vector2d(0.3, 1.5);
  h.noise_variance = 0.01;
  return h;
}

// A warm start far from Truth() (and from the data-driven default start).
Hyperparameters FarFromTruth() {
  Hyperparameters h;
  h.signal_variance = 5.0;
  h.lengthscales = Eigen::Vector2d(3.0, 0.1);
  h.noise_variance = 0.3;
  return h;
}

TEST(HyperparameterFitTest, RecoversKnownGp) {
  Eigen::MatrixXd x;
  Eigen::VectorXd y;
  const Hyperparameters truth = Truth();
  SampleFromGp(truth, 250, 1, &x, &y);
  Hyperparameters start;
  start.lengthscales = Eigen::Vector2d(1.0, 1.0);
  GpModel gp;
  ASSERT_TRUE(gp.Reset(x, y, start).ok());
  const absl::StatusOr<FitSummary> summary =
      FitHyperparameters(FitOptions{}, 1e-4, /*fit_noise=*/true, std::nullopt, &gp);
  ASSERT_TRUE(summary.ok()) << summary.status();
  EXPECT_TRUE(summary->fitted);
  EXPECT_EQ(summary->starts, 1 + FitOptions{}.restarts);
  const Hyperparameters& h = gp.hyperparameters();
  EXPECT_NEAR(std::log(h.lengthscales(0)), std::log(truth.lengthscales(0)),
              std::log(1.5));
  EXPECT_NEAR(std::log(h.lengthscales(1)), std::log(truth.lengthscales(1)),
              std::log(2.0));
  EXPECT_NEAR(std::log(h.noise_variance), std::log(truth.noise_variance), std::log(2.0));
  EXPECT_NEAR(std::log(h.signal_variance), std::log(truth.signal_variance),
              std::log(4.0));
  // The model is left factorised at the reported optimum.
  const testing::ReferenceGp ref(x, y, h);
  EXPECT_LT(testing::RelErr(gp.log_marginal_likelihood(), ref.LogMarginalLikelihood()),
            1e-8);
  // ... which is a stationary point: the projected gradient vanishes at interior
  // parameters.
  const Eigen::VectorXd g = gp.LogMarginalLikelihoodGradient();
  EXPECT_LT(g.cwiseAbs().maxCoeff(), 1e-2 * 250);
}

TEST(HyperparameterFitTest, FittedLmlIsAtLeastThatOfEveryStart) {
  Eigen::MatrixXd x;
  Eigen::VectorXd y;
  SampleFromGp(Truth(), 80, 2, &x, &y);
  const Hyperparameters warm = FarFromTruth();
  Hyperparameters def;
  def.signal_variance = 1.0;
  def.lengthscales = Eigen::Vector2d(1.0, 1.0);
  def.noise_variance = 1e-2;
  const double lml_warm = testing::ReferenceGp(x, y, warm).LogMarginalLikelihood();
  const double lml_default = testing::ReferenceGp(x, y, def).LogMarginalLikelihood();
  GpModel gp;
  ASSERT_TRUE(gp.Reset(x, y, warm).ok());
  FitOptions options;
  options.max_iterations = 5;  // even a short fit must not end below its starts
  const absl::StatusOr<FitSummary> summary =
      FitHyperparameters(options, 1e-4, true, warm, &gp);
  ASSERT_TRUE(summary.ok()) << summary.status();
  EXPECT_EQ(summary->starts, 2 + options.warm_restarts);
  EXPECT_GE(gp.log_marginal_likelihood(), lml_warm);
  EXPECT_GE(gp.log_marginal_likelihood(), lml_default);
}

TEST(HyperparameterFitTest, FixedNoiseStaysFixedAndBoundsHold) {
  Eigen::MatrixXd x;
  Eigen::VectorXd y;
  SampleFromGp(Truth(), 60, 3, &x, &y);
  GpModel gp;
  ASSERT_TRUE(gp.Reset(x, y, Truth()).ok());
  FitOptions options;
  options.min_lengthscale = 0.5;  // truth 0.3 is below: must end on the bound
  ASSERT_TRUE(
      FitHyperparameters(options, 0.02, /*fit_noise=*/false, std::nullopt, &gp).ok());
  EXPECT_EQ(gp.hyperparameters().noise_variance, 0.02);
  EXPECT_GE(gp.hyperparameters().lengthscales.minCoeff(), 0.5 * (1 - 1e-12));
  EXPECT_LE(gp.hyperparameters().lengthscales.maxCoeff(), options.max_lengthscale);
  // Fitted noise respects its floor.
  ASSERT_TRUE(
      FitHyperparameters(options, 0.05, /*fit_noise=*/true, std::nullopt, &gp).ok());
  EXPECT_GE(gp.hyperparameters().noise_variance, 0.05 * (1 - 1e-12));
}

// A cold fit on more than 2 * presearch_size samples runs its starts on a subset
// and polishes the best on all data: it ends at a stationary point of the full
// LML, the optimum the multi-start fit on all data finds, for fewer evaluations
// on all data.
TEST(HyperparameterFitTest, PresearchOnASubsetFindsTheFullDataOptimum) {
  Eigen::MatrixXd x;
  Eigen::VectorXd y;
  const int n = 600;
  SampleFromGp(Truth(), n, 7, &x, &y);
  FitOptions with;
  with.presearch_size = 120;
  FitOptions without = with;
  without.presearch_size = 0;
  GpModel a, b;
  ASSERT_TRUE(a.Reset(x, y, FarFromTruth()).ok());
  ASSERT_TRUE(b.Reset(x, y, FarFromTruth()).ok());
  const absl::StatusOr<FitSummary> presearched =
      FitHyperparameters(with, 1e-4, true, std::nullopt, &a);
  const absl::StatusOr<FitSummary> full =
      FitHyperparameters(without, 1e-4, true, std::nullopt, &b);
  ASSERT_TRUE(presearched.ok()) << presearched.status();
  ASSERT_TRUE(full.ok()) << full.status();
  EXPECT_GT(presearched->presearch_evaluations, 0);
  EXPECT_EQ(full->presearch_evaluations, 0);
  EXPECT_EQ(presearched->starts, (1 + with.restarts) + 1);
  EXPECT_LT(presearched->evaluations - presearched->presearch_evaluations,
            full->evaluations / 2);
  EXPECT_NEAR(a.log_marginal_likelihood(), b.log_marginal_likelihood(), 0.05);
  const testing::ReferenceGp ref(x, y, a.hyperparameters());
  EXPECT_LT(testing::RelErr(a.log_marginal_likelihood(), ref.LogMarginalLikelihood()),
            1e-8);
  EXPECT_LT(a.LogMarginalLikelihoodGradient().cwiseAbs().maxCoeff(), 1e-2 * n);
}

// An input the data ignores ends at a long lengthscale; a cold fit then runs one
// more start with it back at 1 (and less noise), keeps the better optimum, and the
// input goes back out.
TEST(HyperparameterFitTest, ReactivationStartRunsWhenAnInputIsParked) {
  Hyperparameters truth = Truth();
  truth.lengthscales = Eigen::Vector3d(0.3, 1.5, 1e4);  // the third input is ignored
  Eigen::MatrixXd x;
  Eigen::VectorXd y;
  SampleFromGp(truth, 150, 8, &x, &y);
  FitOptions with;
  FitOptions without = with;
  without.reactivate_above = 0.0;
  Hyperparameters start = truth;
  start.lengthscales.setOnes();
  GpModel a, b;
  ASSERT_TRUE(a.Reset(x, y, start).ok());
  ASSERT_TRUE(b.Reset(x, y, start).ok());
  const absl::StatusOr<FitSummary> reactivated =
      FitHyperparameters(with, 1e-4, true, std::nullopt, &a);
  const absl::StatusOr<FitSummary> plain =
      FitHyperparameters(without, 1e-4, true, std::nullopt, &b);
  ASSERT_TRUE(reactivated.ok() && plain.ok());
  EXPECT_EQ(plain->starts, 1 + with.restarts);
  EXPECT_EQ(reactivated->starts, 1 + with.restarts + 1);
  EXPECT_GE(a.log_marginal_likelihood(), b.log_marginal_likelihood() - 1e-9);
  EXPECT_GT(a.hyperparameters().lengthscales(2), with.reactivate_above);
  // Warm fits never run it.
  const absl::StatusOr<FitSummary> warm =
      FitHyperparameters(with, 1e-4, true, a.hyperparameters(), &a);
  ASSERT_TRUE(warm.ok());
  EXPECT_EQ(warm->starts, 2 + with.warm_restarts);
}

TEST(HyperparameterFitTest, DeterministicForSeed) {
  Eigen::MatrixXd x;
  Eigen::VectorXd y;
  SampleFromGp(Truth(), 60, 4, &x, &y);
  FitOptions options;
  options.restarts = 3;
  options.seed = 42;
  GpModel a, b;
  ASSERT_TRUE(a.Reset(x, y, Truth()).ok());
  ASSERT_TRUE(b.Reset(x, y, Truth()).ok());
  ASSERT_TRUE(FitHyperparameters(options, 1e-3, true, std::nullopt, &a).ok());
  ASSERT_TRUE(FitHyperparameters(options, 1e-3, true, std::nullopt, &b).ok());
  EXPECT_EQ(a.hyperparameters().lengthscales, b.hyperparameters().lengthscales);
  EXPECT_EQ(a.hyperparameters().noise_variance, b.hyperparameters().noise_variance);
}

// A stop after k evaluations: exactly k evaluations ran, the remaining starts were
// skipped, and the model holds the best point seen (LML of the warm start or
// better); a stop before any evaluation leaves the warm start.
TEST(HyperparameterFitTest, StopEndsTheFitWithTheBestPointSoFar) {
  Eigen::MatrixXd x;
  Eigen::VectorXd y;
  SampleFromGp(Truth(), 80, 6, &x, &y);
  const Hyperparameters warm = FarFromTruth();
  const double lml_warm = testing::ReferenceGp(x, y, warm).LogMarginalLikelihood();
  FitOptions options;
  options.warm_restarts = 2;
  GpModel full;
  ASSERT_TRUE(full.Reset(x, y, warm).ok());
  const absl::StatusOr<FitSummary> unstopped =
      FitHyperparameters(options, 1e-4, true, warm, &full);
  ASSERT_TRUE(unstopped.ok()) << unstopped.status();
  EXPECT_FALSE(unstopped->stopped);
  ASSERT_GT(unstopped->evaluations, 8);

  int calls = 0;
  const FitStopFn after_five = [&calls]() { return ++calls > 5; };
  GpModel gp;
  ASSERT_TRUE(gp.Reset(x, y, warm).ok());
  const absl::StatusOr<FitSummary> stopped =
      FitHyperparameters(options, 1e-4, true, warm, &gp, after_five);
  ASSERT_TRUE(stopped.ok()) << stopped.status();
  EXPECT_TRUE(stopped->stopped);
  EXPECT_EQ(stopped->evaluations, 5);
  EXPECT_EQ(stopped->starts, 1);  // the other starts were skipped
  EXPECT_GT(gp.log_marginal_likelihood(), lml_warm);
  EXPECT_LE(gp.log_marginal_likelihood(), full.log_marginal_likelihood() + 1e-9);
  const testing::ReferenceGp ref(x, y, gp.hyperparameters());
  EXPECT_LT(testing::RelErr(gp.log_marginal_likelihood(), ref.LogMarginalLikelihood()),
            1e-8);

  GpModel at_once;
  ASSERT_TRUE(at_once.Reset(x, y, Truth()).ok());
  const absl::StatusOr<FitSummary> none =
      FitHyperparameters(options, 1e-4, true, warm, &at_once, [] { return true; });
  ASSERT_TRUE(none.ok()) << none.status();
  EXPECT_TRUE(none->stopped);
  EXPECT_EQ(none->evaluations, 0);
  EXPECT_TRUE(at_once.hyperparameters().lengthscales.isApprox(warm.lengthscales, 1e-12));
  EXPECT_LT(testing::RelErr(at_once.log_marginal_likelihood(), lml_warm), 1e-8);
}

TEST(HyperparameterFitTest, RejectsBadOptions) {
  Eigen::MatrixXd x;
  Eigen::VectorXd y;
  SampleFromGp(Truth(), 10, 5, &x, &y);
  GpModel gp;
  ASSERT_TRUE(gp.Reset(x, y, Truth()).ok());
  FitOptions options;
  options.min_lengthscale = 10.0;
  options.max_lengthscale = 1.0;
  EXPECT_EQ(FitHyperparameters(options, 1e-3, true, std::nullopt, &gp).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(
      FitHyperparameters(FitOptions{}, -1.0, true, std::nullopt, &gp).status().code(),
      absl::StatusCode::kInvalidArgument);
  GpModel empty;
  EXPECT_EQ(
      FitHyperparameters(FitOptions{}, 1e-3, true, std::nullopt, &empty).status().code(),
      absl::StatusCode::kInvalidArgument);
}

TEST(HitBoundsTest, FlagsValuesWithinOnePercentOfABound) {
  FitOptions options;  // lengthscales [0.05, 50], signal variance [0.01, 100]
  Hyperparameters h;
  h.lengthscales = Eigen::Vector4d(0.05 * 1.009, 0.05 * 1.011, 50.0 / 1.009, 3.0);
  h.signal_variance = 100.0;
  BoundHits hits = HitBounds(h, options);
  EXPECT_EQ(hits.lengthscales, (std::vector<int>{0, 2}));
  EXPECT_TRUE(hits.signal_variance);
  h.signal_variance = 0.5;
  EXPECT_FALSE(HitBounds(h, options).signal_variance);
}

}  // namespace
}  // namespace excite::gp
