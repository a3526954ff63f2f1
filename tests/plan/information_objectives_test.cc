// The joint-covariance strategies (mi, roi) on a real gp::DynamicsModel: the GP's
// posterior covariances against a closed form written here, every analytic
// gradient against central differences and Ipopt's derivative checker, and the
// planner end to end.
#include "server/plan/information_objectives.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "server/gp/dynamics_model.h"
#include "server/plan/multiple_shooting_nlp.h"
#include "server/plan/planner.h"
#include "server/plan/reference_set.h"
#include "tests/plan/analytic_predictor.h"
#include "tests/plan/pendulum_gp.h"

namespace excite::plan {
namespace {

using testing::CheckerStart;
using testing::DerivativeCheckerLog;
using testing::FittedModel;

const Eigen::Vector3d kLower(-3.14159, -8.0, -3.0);
const Eigen::Vector3d kUpper(3.14159, 8.0, 3.0);

Eigen::MatrixXd RandomPoints(int m, uint64_t seed) {
  std::mt19937_64 rng(seed);
  Eigen::MatrixXd z(m, 3);
  for (int i = 0; i < m; ++i) {
    for (int l = 0; l < 3; ++l) {
      z(i, l) =
          std::uniform_real_distribution<double>(0.6 * kLower(l), 0.6 * kUpper(l))(rng);
    }
  }
  return z;
}

// SE-ARD kernel in data units, written independently of server/gp.
Eigen::MatrixXd Kernel(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b,
                       const gp::Hyperparameters& h) {
  Eigen::MatrixXd k(a.rows(), b.rows());
  for (Eigen::Index i = 0; i < a.rows(); ++i) {
    for (Eigen::Index j = 0; j < b.rows(); ++j) {
      const double d2 =
          (a.row(i) - b.row(j)).cwiseQuotient(h.lengthscales.transpose()).squaredNorm();
      k(i, j) = h.signal_variance * std::exp(-0.5 * d2);
    }
  }
  return k;
}

// Central differences of f (a function of one M x z_dim matrix) at z.
template <typename F>
Eigen::MatrixXd NumericGradient(const F& f, const Eigen::MatrixXd& z) {
  Eigen::MatrixXd g(z.rows(), z.cols());
  for (Eigen::Index i = 0; i < z.rows(); ++i) {
    for (Eigen::Index l = 0; l < z.cols(); ++l) {
      const double h = 1e-5 * (kUpper(l) - kLower(l));
      Eigen::MatrixXd zp = z, zm = z;
      zp(i, l) += h;
      zm(i, l) -= h;
      g(i, l) = (f(zp) - f(zm)) / (2 * h);
    }
  }
  return g;
}

void ExpectGradientNear(const Eigen::MatrixXd& analytic, const Eigen::MatrixXd& numeric) {
  ASSERT_EQ(analytic.rows(), numeric.rows());
  ASSERT_EQ(analytic.cols(), numeric.cols());
  const double scale = std::max(1.0, numeric.cwiseAbs().maxCoeff());
  EXPECT_LE((analytic - numeric).cwiseAbs().maxCoeff(), 1e-5 * scale)
      << "analytic\n"
      << analytic << "\nnumeric\n"
      << numeric;
}

TEST(PosteriorCovarianceTest, MatchesTheClosedFormAndThePredictedVariance) {
  // A model on samples the test keeps: 60 noisy pendulum steps.
  gp::DynamicsModelOptions o;
  o.state_dim = 2;
  o.input_dim = 1;
  o.measurement_noise_variance = 0.05;
  o.input_center = Eigen::Vector3d(0.0, 0.0, 0.0);
  o.input_half_width = Eigen::Vector3d(3.14159, 8.0, 3.0);
  auto created = gp::DynamicsModel::Create(o);
  ASSERT_TRUE(created.ok());
  gp::DynamicsModel model = *std::move(created);
  Eigen::MatrixXd x(60, 3), next(60, 2);
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, std::sqrt(0.05));
  Eigen::Vector2d s(0.4, 0.0);
  for (int k = 0; k < 60; ++k) {
    const double u = 2.5 * std::sin(0.37 * k);
    const Eigen::Vector2d s1 = testing::PendulumStep(s, u);
    x(k, 0) = s(0) + noise(rng);
    x(k, 1) = s(1) + noise(rng);
    x(k, 2) = u;
    next(k, 0) = s1(0) + noise(rng);
    next(k, 1) = s1(1) + noise(rng);
    s = s1;
  }
  ASSERT_TRUE(model.AddSamples(x.leftCols(2), x.rightCols(1), next).ok());
  ASSERT_TRUE(model.Refit().ok());
  const Eigen::MatrixXd a = RandomPoints(5, 1);
  const Eigen::MatrixXd b = RandomPoints(7, 2);
  const auto pa = model.PreparePoints(a);
  const auto pb = model.PreparePoints(b);
  ASSERT_NE(pa, nullptr);
  const std::vector<Eigen::MatrixXd> cov = model.PosteriorCovariance(*pa, *pb);
  const std::vector<Eigen::MatrixXd> self = model.PosteriorCovariance(*pa, *pa);
  Eigen::MatrixXd mean, variance;
  model.Predict(a, &mean, &variance, nullptr, nullptr);
  ASSERT_EQ(cov.size(), 2u);
  const std::vector<gp::Hyperparameters> h = model.hyperparameters();
  for (int j = 0; j < 2; ++j) {
    Eigen::MatrixXd kxx = Kernel(x, x, h[j]);
    kxx.diagonal().array() += h[j].noise_variance;
    const Eigen::LLT<Eigen::MatrixXd> llt(kxx);
    const Eigen::MatrixXd expected =
        Kernel(a, b, h[j]) - Kernel(a, x, h[j]) * llt.solve(Kernel(x, b, h[j]));
    const double scale = h[j].signal_variance;
    EXPECT_LE((cov[j] - expected).cwiseAbs().maxCoeff(), 1e-9 * scale) << j;
    EXPECT_LE((self[j].diagonal() - variance.col(j)).cwiseAbs().maxCoeff(), 1e-9 * scale);
    EXPECT_LE((self[j] - self[j].transpose()).cwiseAbs().maxCoeff(), 1e-12 * scale);
  }
}

TEST(PosteriorCovarianceTest, GradientMatchesCentralDifferences) {
  const gp::DynamicsModel model = FittedModel(60);
  const Eigen::MatrixXd a = RandomPoints(4, 3);
  const Eigen::MatrixXd b = RandomPoints(6, 4);
  std::mt19937_64 rng(9);
  std::normal_distribution<double> normal;
  std::vector<Eigen::MatrixXd> w(2, Eigen::MatrixXd(4, 6)), ws(2, Eigen::MatrixXd(4, 4));
  for (int j = 0; j < 2; ++j) {
    for (int i = 0; i < 4; ++i) {
      for (int k = 0; k < 6; ++k) w[j](i, k) = normal(rng);
      for (int k = 0; k <= i; ++k) ws[j](i, k) = ws[j](k, i) = normal(rng);
    }
  }
  const auto pb = model.PreparePoints(b);
  // Cross term: b fixed.
  const auto cross = [&](const Eigen::MatrixXd& z) {
    const auto pz = model.PreparePoints(z);
    const auto c = model.PosteriorCovariance(*pz, *pb);
    return c[0].cwiseProduct(w[0]).sum() + c[1].cwiseProduct(w[1]).sum();
  };
  const auto pa = model.PreparePoints(a);
  ExpectGradientNear(model.PosteriorCovarianceGradient(*pa, {{pb.get(), &w}}),
                     NumericGradient(cross, a));
  // Symmetric term: both arguments move, weights doubled.
  const auto symmetric = [&](const Eigen::MatrixXd& z) {
    const auto pz = model.PreparePoints(z);
    const auto c = model.PosteriorCovariance(*pz, *pz);
    return c[0].cwiseProduct(ws[0]).sum() + c[1].cwiseProduct(ws[1]).sum();
  };
  std::vector<Eigen::MatrixXd> doubled = {2.0 * ws[0], 2.0 * ws[1]};
  ExpectGradientNear(model.PosteriorCovarianceGradient(*pa, {{pa.get(), &doubled}}),
                     NumericGradient(symmetric, a));
  // Both terms at once (one shared solve) are the sum of the two.
  ExpectGradientNear(
      model.PosteriorCovarianceGradient(*pa, {{pb.get(), &w}, {pa.get(), &doubled}}),
      NumericGradient([&](const Eigen::MatrixXd& z) { return cross(z) + symmetric(z); },
                      a));
}

TEST(MutualInformationTest, ClosedFormForOnePointAndNoDoubleCounting) {
  const gp::DynamicsModel model = FittedModel(80);
  auto objective = NegativeMutualInformationObjective::Create(model);
  ASSERT_TRUE(objective.ok()) << objective.status();
  const Eigen::MatrixXd z = RandomPoints(1, 5);
  Eigen::MatrixXd mean, variance;
  model.Predict(z, &mean, &variance, nullptr, nullptr);
  const Eigen::VectorXd noise = model.noise_variances();
  double expected = 0.0;
  for (int j = 0; j < 2; ++j) expected += 0.5 * std::log1p(variance(0, j) / noise(j));
  EXPECT_NEAR(-(*objective)->Evaluate(z, mean, variance, nullptr, nullptr, nullptr),
              expected, 1e-10);
  // The same point twice is worth less than twice the point (and more than once).
  Eigen::MatrixXd twice(2, 3);
  twice << z, z;
  const double mi_twice =
      -(*objective)->Evaluate(twice, mean, variance, nullptr, nullptr, nullptr);
  EXPECT_GT(mi_twice, expected + 1e-6);
  EXPECT_LT(mi_twice, 2.0 * expected - 1e-6);
}

TEST(MutualInformationTest, GradientMatchesCentralDifferences) {
  const gp::DynamicsModel model = FittedModel(80);
  auto objective = NegativeMutualInformationObjective::Create(model);
  ASSERT_TRUE(objective.ok()) << objective.status();
  const Eigen::MatrixXd z = RandomPoints(6, 6);
  const Eigen::MatrixXd unused;
  const auto f = [&](const Eigen::MatrixXd& p) {
    return (*objective)->Evaluate(p, unused, unused, nullptr, nullptr, nullptr);
  };
  Eigen::MatrixXd gradient;
  const std::vector<Eigen::MatrixXd> none;
  (*objective)->Evaluate(z, unused, unused, &none, &none, &gradient);
  ExpectGradientNear(gradient, NumericGradient(f, z));
}

TEST(VarianceReductionTest, GradientMatchesCentralDifferencesAndValueIsAFraction) {
  const gp::DynamicsModel model = FittedModel(80);
  const Eigen::MatrixXd reference = HaltonReferenceSet(kLower, kUpper, 64, 3);
  auto objective = NegativeVarianceReductionObjective::Create(model, reference);
  ASSERT_TRUE(objective.ok()) << objective.status();
  const Eigen::MatrixXd z = RandomPoints(6, 7);
  const Eigen::MatrixXd unused;
  const auto f = [&](const Eigen::MatrixXd& p) {
    return (*objective)->Evaluate(p, unused, unused, nullptr, nullptr, nullptr);
  };
  const double value = f(z);
  EXPECT_LT(value, 0.0);
  EXPECT_GT(value, -1.0);
  Eigen::MatrixXd gradient;
  const std::vector<Eigen::MatrixXd> none;
  (*objective)->Evaluate(z, unused, unused, &none, &none, &gradient);
  ExpectGradientNear(gradient, NumericGradient(f, z));

  // Observing the reference points themselves (exactly, in the limit) removes
  // more than any 6 points do; a point far outside the region removes ~nothing.
  Eigen::MatrixXd far = z;
  far.col(1).setConstant(200.0);
  EXPECT_GT(f(far), -1e-6);
}

TEST(VarianceReductionTest, ClosedFormForOnePoint) {
  const gp::DynamicsModel model = FittedModel(80);
  const Eigen::MatrixXd reference = HaltonReferenceSet(kLower, kUpper, 32, 1);
  auto objective = NegativeVarianceReductionObjective::Create(model, reference);
  ASSERT_TRUE(objective.ok());
  const Eigen::MatrixXd z = RandomPoints(1, 8);
  const auto pz = model.PreparePoints(z);
  const auto pr = model.PreparePoints(reference);
  const auto c = model.PosteriorCovariance(*pz, *pr);
  const auto s = model.PosteriorCovariance(*pz, *pz);
  Eigen::MatrixXd mean, variance;
  model.Predict(reference, &mean, &variance, nullptr, nullptr);
  const Eigen::VectorXd noise = model.noise_variances();
  double removed = 0.0;
  for (int j = 0; j < 2; ++j) {
    removed += c[j].squaredNorm() / (s[j](0, 0) + noise(j));
  }
  EXPECT_NEAR(-(*objective)->Evaluate(z, mean, variance, nullptr, nullptr, nullptr),
              removed / variance.sum(), 1e-12);
  EXPECT_NEAR((*objective)->total_variance(), variance.sum(), 1e-12);
}

TEST(InformationObjectivesTest, IpoptDerivativeCheckerOnTheGp) {
  const gp::DynamicsModel model = FittedModel(80);
  Eigen::MatrixXd inputs, states;
  CheckerStart(&inputs, &states);
  auto mi = NegativeMutualInformationObjective::Create(model);
  auto roi = NegativeVarianceReductionObjective::Create(
      model, HaltonReferenceSet(kLower, kUpper, 64, 2));
  ASSERT_TRUE(mi.ok());
  ASSERT_TRUE(roi.ok());
  for (const ShootingObjective* objective :
       {static_cast<const ShootingObjective*>(mi->get()),
        static_cast<const ShootingObjective*>(roi->get())}) {
    Ipopt::SmartPtr<MultipleShootingNlp> nlp = new MultipleShootingNlp(
        model, *objective, Eigen::Vector2d(0.1, -0.2), Eigen::VectorXd::Constant(1, -3.0),
        Eigen::VectorXd::Constant(1, 3.0), inputs, states);
    const std::string log = DerivativeCheckerLog(nlp);
    EXPECT_NE(log.find("No errors detected by derivative checker"), std::string::npos)
        << log;
  }
}

PlanOptions Options(Strategy strategy) {
  PlanOptions o;
  o.strategy = strategy;
  o.horizon = 10;
  o.input_lower = Eigen::VectorXd::Constant(1, -3.0);
  o.input_upper = Eigen::VectorXd::Constant(1, 3.0);
  o.state_lower = kLower.head(2);
  o.state_upper = kUpper.head(2);
  o.roi_reference_points = 128;
  return o;
}

TEST(InformationPlannerTest, MiAndRoiPlanBetterThanTheirStartsAndRandomSequences) {
  const gp::DynamicsModel model = FittedModel(150);
  const Eigen::VectorXd x0 = Eigen::Vector2d(0.3, -0.5);
  for (Strategy strategy : {Strategy::kMi, Strategy::kRoi}) {
    Planner planner(Options(strategy));
    PlanSummary summary;
    const auto plan = planner.PlanInputs(model, x0, 0, PlanLimits{}, &summary);
    ASSERT_TRUE(plan.ok()) << plan.status();
    ASSERT_EQ(plan->inputs.rows(), 10);
    EXPECT_EQ(plan->apply_count, 1);
    EXPECT_LE(plan->inputs.cwiseAbs().maxCoeff(), 3.0);
    EXPECT_GT(summary.objective, 0.0);
    // The planned value against 50 random input sequences rolled out.
    const Eigen::MatrixXd reference = HaltonReferenceSet(kLower, kUpper, 128, 0);
    auto mi = NegativeMutualInformationObjective::Create(model);
    auto roi = NegativeVarianceReductionObjective::Create(model, reference);
    const ShootingObjective& objective =
        strategy == Strategy::kMi ? static_cast<const ShootingObjective&>(**mi)
                                  : static_cast<const ShootingObjective&>(**roi);
    std::mt19937_64 rng(4);
    std::uniform_real_distribution<double> u(-3.0, 3.0);
    double best_random = -1e300;
    for (int r = 0; r < 50; ++r) {
      Eigen::VectorXd x = x0;
      Eigen::MatrixXd z(10, 3);
      for (int i = 0; i < 10; ++i) {
        z.row(i) << x.transpose(), u(rng);
        Eigen::MatrixXd mean, var;
        model.Predict(z.row(i), &mean, &var, nullptr, nullptr);
        x = mean.row(0).transpose();
      }
      best_random =
          std::max(best_random, -objective.Evaluate(z, z, z, nullptr, nullptr, nullptr));
    }
    EXPECT_GE(summary.objective, best_random) << static_cast<int>(strategy);
    RecordProperty(strategy == Strategy::kMi ? "mi_plan_ms" : "roi_plan_ms",
                   std::to_string(summary.wall_time_ms));
  }
}

TEST(InformationPlannerTest, RoiNeedsStateBoundsAndMiNeedsJointCovariances) {
  const gp::DynamicsModel model = FittedModel(40);
  PlanOptions o = Options(Strategy::kRoi);
  o.state_lower.resize(0);
  o.state_upper.resize(0);
  Planner roi(o);
  PlanSummary summary;
  auto plan = roi.PlanInputs(model, Eigen::Vector2d(0.0, 0.0), 0, PlanLimits{}, &summary);
  EXPECT_EQ(plan.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(plan.status().message().find("roi needs state bounds"), std::string::npos);

  const testing::AnalyticPendulum analytic;
  Planner mi(Options(Strategy::kMi));
  plan = mi.PlanInputs(analytic, Eigen::Vector2d(0.0, 0.0), 0, PlanLimits{}, &summary);
  EXPECT_EQ(plan.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(plan.status().message().find("joint posterior covariances"),
            std::string::npos)
      << plan.status();
}

TEST(ReferenceSetTest, EvenInsideTheBoxAndSeeded) {
  const Eigen::Vector2d lower(-1.0, 2.0), upper(3.0, 2.5);
  const Eigen::MatrixXd a = HaltonReferenceSet(lower, upper, 200, 5);
  EXPECT_EQ(a, HaltonReferenceSet(lower, upper, 200, 5));
  EXPECT_NE(a, HaltonReferenceSet(lower, upper, 200, 6));
  for (int l = 0; l < 2; ++l) {
    EXPECT_GE(a.col(l).minCoeff(), lower(l));
    EXPECT_LT(a.col(l).maxCoeff(), upper(l));
    // Low discrepancy: each of 10 bins of a dimension holds 20 +- 2 points
    // (uniform random points would miss that often).
    std::vector<int> bins(10, 0);
    for (int i = 0; i < 200; ++i) {
      ++bins[static_cast<size_t>((a(i, l) - lower(l)) / (upper(l) - lower(l)) * 10)];
    }
    for (int count : bins) EXPECT_NEAR(count, 20, 2) << l;
  }
  // Joint: 4 x 4 cells of the square each hold 200/16 = 12.5 +- 3.
  std::vector<int> cells(16, 0);
  for (int i = 0; i < 200; ++i) {
    const int c0 = static_cast<int>((a(i, 0) - lower(0)) / (upper(0) - lower(0)) * 4);
    const int c1 = static_cast<int>((a(i, 1) - lower(1)) / (upper(1) - lower(1)) * 4);
    ++cells[static_cast<size_t>(4 * c0 + c1)];
  }
  for (int count : cells) EXPECT_NEAR(count, 12.5, 3.0);
}

}  // namespace
}  // namespace excite::plan
