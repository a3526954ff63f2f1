// sep's search: PointEntropy's gradient and SearchMaxEntropy (multi-start
// L-BFGS-B over a box) on the analytic stand-in model.
#include "server/plan/entropy_search.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

#include "tests/plan/analytic_predictor.h"

namespace excite::plan {
namespace {

using ::excite::plan::testing::AnalyticPendulum;
using ::excite::plan::testing::WrappedPredictor;

// Largest relative error of PointEntropy's gradient against central differences
// at a few random points.
double WorstGradientError(const gp::DynamicsPredictor& model) {
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> u(-1.5, 1.5);
  double worst = 0.0;
  for (int p = 0; p < 20; ++p) {
    Eigen::VectorXd z(model.z_dim());
    for (Eigen::Index l = 0; l < z.size(); ++l) z(l) = u(rng);
    Eigen::VectorXd grad;
    PointEntropy(model, z, &grad);
    for (Eigen::Index l = 0; l < z.size(); ++l) {
      const double h = 1e-6;
      Eigen::VectorXd zp = z, zm = z;
      zp(l) += h;
      zm(l) -= h;
      const double fd =
          (PointEntropy(model, zp, nullptr) - PointEntropy(model, zm, nullptr)) / (2 * h);
      worst = std::max(worst, std::abs(grad(l) - fd) / std::max(1e-3, std::abs(fd)));
    }
  }
  return worst;
}

TEST(EntropySearchTest, GradientMatchesFiniteDifferences) {
  for (int du : {1, 2}) {
    const AnalyticPendulum model(du);
    EXPECT_LT(WorstGradientError(model), 1e-5) << "du=" << du;
  }
  // The check can fail: a wrong variance Jacobian gives a wrong gradient.
  const AnalyticPendulum model(2);
  const WrappedPredictor wrong(model, 1.0, 1.3);
  EXPECT_GT(WorstGradientError(wrong), 0.1);
}

TEST(EntropySearchTest, BeatsThousandRandomSamplesOfTheBox) {
  for (int du : {1, 2}) {
    SCOPED_TRACE(du);
    const AnalyticPendulum model(du);
    Eigen::VectorXd lower(2 + du), upper(2 + du);
    lower << -1.0, -2.0, Eigen::VectorXd::Constant(du, -0.5);
    upper << 0.5, 1.0, Eigen::VectorXd::Constant(du, 1.5);
    EntropySearchOptions options;
    options.seed = 3;
    options.samples = 64;
    const EntropySearchResult result =
        SearchMaxEntropy(model, lower, upper, options, nullptr);
    ASSERT_EQ(result.z.size(), 2 + du);
    EXPECT_TRUE((result.z.array() >= lower.array()).all());
    EXPECT_TRUE((result.z.array() <= upper.array()).all());
    EXPECT_NEAR(result.entropy, PointEntropy(model, result.z, nullptr), 1e-12);
    EXPECT_GT(result.iterations, 0);
    EXPECT_FALSE(result.stopped);

    std::mt19937_64 rng(99);
    double best_random = -1e300;
    for (int s = 0; s < 1000; ++s) {
      Eigen::VectorXd z(2 + du);
      for (int l = 0; l < 2 + du; ++l) {
        z(l) = std::uniform_real_distribution<double>(lower(l), upper(l))(rng);
      }
      best_random = std::max(best_random, PointEntropy(model, z, nullptr));
    }
    EXPECT_GE(result.entropy, best_random);
    RecordProperty("search_entropy_du" + std::to_string(du),
                   std::to_string(result.entropy));
    RecordProperty("best_random_entropy_du" + std::to_string(du),
                   std::to_string(best_random));

    // Deterministic for a seed.
    const EntropySearchResult again =
        SearchMaxEntropy(model, lower, upper, options, nullptr);
    EXPECT_EQ(again.z, result.z);
  }
}

TEST(EntropySearchTest, StopKeepsTheBestSample) {
  const AnalyticPendulum model(1);
  const Eigen::Vector3d lower(-1, -1, -1), upper(1, 1, 1);
  const EntropySearchResult result =
      SearchMaxEntropy(model, lower, upper, EntropySearchOptions{}, [] { return true; });
  EXPECT_TRUE(result.stopped);
  EXPECT_EQ(result.iterations, 0);
  ASSERT_EQ(result.z.size(), 3);  // the best of the random batch
  EXPECT_TRUE((result.z.array() >= lower.array()).all());
  EXPECT_TRUE((result.z.array() <= upper.array()).all());
  EXPECT_TRUE(std::isfinite(result.entropy));
}

}  // namespace
}  // namespace excite::plan
