#include "server/gp/dynamics_model.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <atomic>
#include <cmath>
#include <functional>
#include <random>
#include <vector>

#include "server/gp/hyperparameters.h"
#include "tests/gp/pendulum_samples.h"
#include "tests/gp/reference_gp.h"

namespace excite::gp {
namespace {

using testing::ReferenceGp;
using testing::RelErr;

constexpr double kNoiseVar = 1e-3;

using testing::DataUnitHyperparameters;
using testing::PendulumTransitions;
using testing::Transitions;
using testing::Z;

Transitions MakeTransitions(int n, uint64_t seed, double noise_var = kNoiseVar) {
  return PendulumTransitions(n, seed, noise_var);
}

DynamicsModelOptions BaseOptions(Target target) {
  DynamicsModelOptions o;
  o.state_dim = 2;
  o.input_dim = 1;
  o.target = target;
  o.measurement_noise_variance = kNoiseVar;
  o.input_center = Eigen::Vector3d(0.0, 0.0, 0.0);
  o.input_half_width = Eigen::Vector3d(3.0, 6.0, 2.0);
  return o;
}

// Fixed data-unit hyperparameters: the model equals a reference GP on raw z and
// raw targets whose constant prior mean is the mean of all targets, also for
// samples appended after the Refit(); mean, variance and LML against the closed
// form, and the same model whichever samples came before the Refit().
TEST(DynamicsModelTest, FixedHyperparametersMatchReferenceInDataUnits) {
  for (Target target : {Target::kDelta, Target::kNext}) {
    DynamicsModelOptions o = BaseOptions(target);
    o.fit_kernel = false;
    o.fixed = DataUnitHyperparameters();
    absl::StatusOr<DynamicsModel> model = DynamicsModel::Create(o);
    ASSERT_TRUE(model.ok()) << model.status();
    const Transitions d = MakeTransitions(40, 1);
    ASSERT_TRUE(
        model->AddSamples(d.x.topRows(30), d.u.topRows(30), d.next.topRows(30)).ok());
    const absl::StatusOr<FitSummary> s = model->Refit();
    ASSERT_TRUE(s.ok()) << s.status();
    EXPECT_FALSE(s->fitted);
    // Appended after the fit: the prior mean moves to the mean of all 40.
    ASSERT_TRUE(
        model->AddSamples(d.x.bottomRows(10), d.u.bottomRows(10), d.next.bottomRows(10))
            .ok());
    EXPECT_EQ(model->samples_since_fit(), 10);
    EXPECT_EQ(model->sample_count(), 40);
    const std::vector<Hyperparameters> reported = model->hyperparameters();
    ASSERT_EQ(reported.size(), 2u);
    const Eigen::MatrixXd targets =
        target == Target::kDelta ? Eigen::MatrixXd(d.next - d.x) : d.next;
    const Transitions test = MakeTransitions(7, 2);
    const Eigen::MatrixXd zt = Z(test);
    Eigen::MatrixXd mean, var;
    model->Predict(zt, &mean, &var, nullptr, nullptr);
    // All 40 samples before the one Refit(): the same model.
    absl::StatusOr<DynamicsModel> at_once = DynamicsModel::Create(o);
    ASSERT_TRUE(at_once.ok()) << at_once.status();
    ASSERT_TRUE(at_once->AddSamples(d.x, d.u, d.next).ok());
    ASSERT_TRUE(at_once->Refit().ok());
    Eigen::MatrixXd mean_at_once, var_at_once;
    at_once->Predict(zt, &mean_at_once, &var_at_once, nullptr, nullptr);
    EXPECT_LT((mean - mean_at_once).cwiseAbs().maxCoeff(), 1e-10);
    EXPECT_LT((var - var_at_once).cwiseAbs().maxCoeff(), 1e-12);
    const std::vector<double> lml = model->log_marginal_likelihoods();
    ASSERT_EQ(lml.size(), 2u);
    for (int j = 0; j < 2; ++j) {
      EXPECT_LT(RelErr(reported[j].signal_variance, o.fixed[j].signal_variance), 1e-12);
      EXPECT_LT((reported[j].lengthscales - o.fixed[j].lengthscales).norm(), 1e-12);
      EXPECT_LT(RelErr(reported[j].noise_variance, o.fixed[j].noise_variance), 1e-12);
      EXPECT_LT(RelErr(model->noise_variances()(j), o.fixed[j].noise_variance), 1e-12);
      const double prior_mean = targets.col(j).mean();
      EXPECT_LT(RelErr(model->prior_means()(j), prior_mean), 1e-12);
      const ReferenceGp ref(Z(d), targets.col(j), o.fixed[j], prior_mean);
      EXPECT_LT(RelErr(lml[j], ref.LogMarginalLikelihood()), 1e-9);
      EXPECT_LT(RelErr(lml[j], at_once->log_marginal_likelihoods()[j]), 1e-10);
      for (int i = 0; i < 7; ++i) {
        const double expected =
            ref.Mean(zt.row(i)) + (target == Target::kDelta ? zt(i, j) : 0.0);
        EXPECT_LT(RelErr(mean(i, j), expected), 1e-8);
        EXPECT_LT(RelErr(var(i, j), ref.Variance(zt.row(i))), 1e-8);
      }
    }
  }
}

// Through the normalisation, in data units, for both targets. With fixed,
// well-conditioned hyperparameters (noise 2e-3..3e-3 against signal 0.5..2) the
// tolerance is 1e-6 relative. A fitted model here has a normalised noise of ~1e-5,
// so the latent variance (~1e-4 of the signal) is computed as a difference of
// nearly equal numbers: finite differences of it are only good to ~1e-5, and the
// tolerances are 1e-5 (mean, large alpha) and 1e-4 (variance) there.
TEST(DynamicsModelTest, JacobiansMatchFiniteDifferencesInDataUnits) {
  for (bool fit : {false, true})
    for (Target target : {Target::kDelta, Target::kNext}) {
      SCOPED_TRACE(::testing::Message()
                   << "fit " << fit << " delta " << (target == Target::kDelta));
      DynamicsModelOptions o = BaseOptions(target);
      o.input_half_width(1) = std::numeric_limits<double>::quiet_NaN();  // from data
      o.input_center(0) = 0.3;
      o.fit_kernel = fit;
      if (!fit) o.fixed = DataUnitHyperparameters();
      const double var_tol = fit ? 1e-4 : 1e-6;
      const double mean_tol = fit ? 1e-5 : 1e-6;
      absl::StatusOr<DynamicsModel> model = DynamicsModel::Create(o);
      ASSERT_TRUE(model.ok());
      const Transitions d = MakeTransitions(60, 3);
      ASSERT_TRUE(model->AddSamples(d.x, d.u, d.next).ok());
      ASSERT_TRUE(model->Refit().ok());
      const Eigen::MatrixXd z = Z(MakeTransitions(5, 4));
      Eigen::MatrixXd mean, var;
      std::vector<Eigen::MatrixXd> dmean, dvar;
      model->Predict(z, &mean, &var, &dmean, &dvar);
      ASSERT_EQ(dmean.size(), 5u);
      // Fourth-order central differences (error O(eps^4)); a fitted model with a
      // small noise has large alpha, so a smaller step would drown in round-off.
      const double eps = 1e-3;
      for (int l = 0; l < 3; ++l) {
        Eigen::MatrixXd fm[4], fv[4];
        const double steps[4] = {-2 * eps, -eps, eps, 2 * eps};
        for (int k = 0; k < 4; ++k) {
          Eigen::MatrixXd zk = z;
          zk.col(l).array() += steps[k];
          model->Predict(zk, &fm[k], &fv[k], nullptr, nullptr);
        }
        const Eigen::MatrixXd fdm = (fm[0] - 8 * fm[1] + 8 * fm[2] - fm[3]) / (12 * eps);
        const Eigen::MatrixXd fdv = (fv[0] - 8 * fv[1] + 8 * fv[2] - fv[3]) / (12 * eps);
        for (int i = 0; i < 5; ++i) {
          for (int j = 0; j < 2; ++j) {
            EXPECT_LT(RelErr(dmean[i](j, l), fdm(i, j), 1e-2), mean_tol)
                << i << j << l << " " << dmean[i](j, l) << " vs " << fdm(i, j);
            EXPECT_LT(RelErr(dvar[i](j, l), fdv(i, j), 1e-2 * var(i, j)), var_tol)
                << i << j << l << " " << dvar[i](j, l) << " vs " << fdv(i, j);
          }
        }
      }
    }
}

TEST(DynamicsModelTest, FitLearnsPendulumAndIsDeterministic) {
  DynamicsModelOptions o = BaseOptions(Target::kDelta);
  o.fit.seed = 7;
  absl::StatusOr<DynamicsModel> a = DynamicsModel::Create(o);
  absl::StatusOr<DynamicsModel> b = DynamicsModel::Create(o);
  ASSERT_TRUE(a.ok() && b.ok());
  const Transitions d = MakeTransitions(200, 5);
  for (DynamicsModel* m : {&*a, &*b}) {
    ASSERT_TRUE(
        m->AddSamples(d.x.topRows(150), d.u.topRows(150), d.next.topRows(150)).ok());
    const absl::StatusOr<FitSummary> cold = m->Refit();
    ASSERT_TRUE(cold.ok()) << cold.status();
    // Each output: the default and random starts, and a reactivation start when an
    // input was parked (the pendulum's angle update ignores the torque).
    EXPECT_GE(cold->starts, 2 * (1 + o.fit.restarts));
    EXPECT_LE(cold->starts, 2 * (2 + o.fit.restarts));
    ASSERT_TRUE(
        m->AddSamples(d.x.bottomRows(50), d.u.bottomRows(50), d.next.bottomRows(50))
            .ok());
    const absl::StatusOr<FitSummary> warm = m->Refit();
    ASSERT_TRUE(warm.ok());
    EXPECT_EQ(warm->starts, 2 * (2 + o.fit.warm_restarts));
  }
  for (int j = 0; j < 2; ++j) {
    EXPECT_EQ(a->hyperparameters()[j].lengthscales, b->hyperparameters()[j].lengthscales);
    EXPECT_EQ(a->hyperparameters()[j].noise_variance,
              b->hyperparameters()[j].noise_variance);
    // Noise variance in data units: floor = measurement noise variance, and a
    // delta target carries about twice that.
    EXPECT_GE(a->noise_variances()(j), kNoiseVar * (1 - 1e-9));
    EXPECT_LT(a->noise_variances()(j), 20 * kNoiseVar);
  }
  // One-step predictions on fresh points, noise-free truth.
  const Transitions test = MakeTransitions(100, 6, 0.0);
  Eigen::MatrixXd mean, var;
  a->Predict(Z(test), &mean, &var, nullptr, nullptr);
  const double rmse = std::sqrt((mean - test.next).squaredNorm() / 100);
  EXPECT_LT(rmse, 0.1);  // the rate changes by up to ~3 per step
  EXPECT_TRUE((var.array() > 0).all());
}

// Four outputs (two pendulums side by side) fitted on one thread, on four, and on
// four whose third and fourth run only if run_if_worker_free lets them: the same
// hyperparameters, to the bit; the gate is asked once per thread beyond two.
TEST(DynamicsModelTest, FitThreadsAndFreeWorkersDoNotChangeTheFit) {
  const Transitions a = MakeTransitions(150, 11);
  const Transitions b = MakeTransitions(150, 12);
  Eigen::MatrixXd x(150, 4), u(150, 2), next(150, 4);
  x << a.x, b.x;
  u << a.u, b.u;
  next << a.next, b.next;
  DynamicsModelOptions o;
  o.state_dim = 4;
  o.input_dim = 2;
  o.measurement_noise_variance = kNoiseVar;
  o.input_center = Eigen::VectorXd::Zero(6);
  o.input_half_width = Eigen::VectorXd(6);
  o.input_half_width << 3.0, 6.0, 3.0, 6.0, 2.0, 2.0;
  const auto fit = [&](int threads,
                       std::function<void(const std::function<void()>&)> gate) {
    DynamicsModelOptions options = o;
    options.fit_threads = threads;
    options.run_if_worker_free = std::move(gate);
    absl::StatusOr<DynamicsModel> model = DynamicsModel::Create(options);
    EXPECT_TRUE(model.ok());
    EXPECT_TRUE(model->AddSamples(x, u, next).ok());
    EXPECT_TRUE(model->Refit().ok());
    return model->hyperparameters();
  };
  const std::vector<Hyperparameters> alone = fit(1, nullptr);
  std::atomic<int> asked{0};
  const std::vector<Hyperparameters> granted =
      fit(4, [&](const std::function<void()>& work) {
        ++asked;
        work();
      });
  EXPECT_EQ(asked.load(), 2);
  const std::vector<Hyperparameters> refused =
      fit(4, [](const std::function<void()>&) {});
  for (const auto* other : {&granted, &refused}) {
    ASSERT_EQ(other->size(), 4u);
    for (int j = 0; j < 4; ++j) {
      EXPECT_EQ((*other)[j].lengthscales, alone[j].lengthscales) << j;
      EXPECT_EQ((*other)[j].signal_variance, alone[j].signal_variance) << j;
      EXPECT_EQ((*other)[j].noise_variance, alone[j].noise_variance) << j;
    }
  }
}

// bound_hits() names the lengthscales a fit left at a bound: recomputed here
// from the data-unit lengthscales and the fixed half-widths (3, 6, 2).
TEST(DynamicsModelTest, BoundHitsAreTheLengthscalesAtTheirBounds) {
  DynamicsModelOptions o = BaseOptions(Target::kDelta);
  o.fit.seed = 3;
  absl::StatusOr<DynamicsModel> model = DynamicsModel::Create(o);
  ASSERT_TRUE(model.ok());
  EXPECT_TRUE(model->bound_hits().empty());  // not fitted
  const Transitions d = MakeTransitions(60, 9);
  ASSERT_TRUE(model->AddSamples(d.x, d.u, d.next).ok());
  ASSERT_TRUE(model->Refit().ok());
  const std::vector<BoundHits> hits = model->bound_hits();
  ASSERT_EQ(hits.size(), 2u);
  const Eigen::Vector3d half_width(3.0, 6.0, 2.0);
  int at_bound = 0;
  for (int j = 0; j < 2; ++j) {
    std::vector<int> expected;
    for (int i = 0; i < 3; ++i) {
      const double l = model->hyperparameters()[j].lengthscales(i) / half_width(i);
      if (std::abs(std::log(l / o.fit.min_lengthscale)) < 0.01 ||
          std::abs(std::log(l / o.fit.max_lengthscale)) < 0.01) {
        expected.push_back(i);
      }
    }
    EXPECT_EQ(hits[j].lengthscales, expected) << j;
    at_bound += static_cast<int>(expected.size());
  }
  // The angle's update does not depend on the torque within a step of 60
  // samples' resolution: that lengthscale is parked at the upper bound.
  EXPECT_GE(at_bound, 1);
}

// A model restored from the same data and the saved hyperparameters (seeded with
// the count they were fitted on, then rebuilt without a fit) predicts what the
// original predicted after samples were appended past its fit.
TEST(DynamicsModelTest, RebuildFromSavedFitPredictsAsTheOriginal) {
  for (Target target : {Target::kDelta, Target::kNext}) {
    const DynamicsModelOptions o = BaseOptions(target);
    absl::StatusOr<DynamicsModel> original = DynamicsModel::Create(o);
    ASSERT_TRUE(original.ok());
    const Transitions d = MakeTransitions(53, 11);
    ASSERT_TRUE(
        original->AddSamples(d.x.topRows(50), d.u.topRows(50), d.next.topRows(50)).ok());
    ASSERT_TRUE(original->Refit().ok());
    ASSERT_TRUE(
        original->AddSamples(d.x.bottomRows(3), d.u.bottomRows(3), d.next.bottomRows(3))
            .ok());

    absl::StatusOr<DynamicsModel> restored = DynamicsModel::Create(o);
    ASSERT_TRUE(restored.ok());
    EXPECT_EQ(restored->Rebuild().code(), absl::StatusCode::kFailedPrecondition);
    ASSERT_TRUE(restored->AddSamples(d.x, d.u, d.next).ok());
    ASSERT_TRUE(restored->SeedWarmStart(original->hyperparameters(), 50).ok());
    EXPECT_EQ(restored->samples_since_fit(), 3);
    ASSERT_TRUE(restored->Rebuild().ok());
    EXPECT_TRUE(restored->fitted());
    EXPECT_EQ(restored->samples_since_fit(), 3);  // a rebuild is not a fit

    const Eigen::MatrixXd zt = Z(MakeTransitions(9, 12));
    Eigen::MatrixXd m1, v1, m2, v2;
    original->Predict(zt, &m1, &v1, nullptr, nullptr);
    restored->Predict(zt, &m2, &v2, nullptr, nullptr);
    EXPECT_LT((m1 - m2).cwiseAbs().maxCoeff(), 1e-9);
    EXPECT_LT((v1 - v2).cwiseAbs().maxCoeff(), 1e-9 * v1.cwiseAbs().maxCoeff());
    EXPECT_LT((original->prior_means() - restored->prior_means()).norm(), 1e-15);
    for (int j = 0; j < 2; ++j) {
      EXPECT_LT(RelErr(original->log_marginal_likelihoods()[j],
                       restored->log_marginal_likelihoods()[j]),
                1e-9);
    }
  }
}

// A copy of the data fits exactly the model a refit in place gives (the session
// fits on one while the other answers), exact and sparse, and is not fitted
// until then.
TEST(DynamicsModelTest, RefitOfACopyOfTheDataIsTheRefitInPlace) {
  for (int sparse_above : {0, 40}) {
    SCOPED_TRACE(sparse_above);
    DynamicsModelOptions o = BaseOptions(Target::kDelta);
    o.sparse_above = sparse_above;
    absl::StatusOr<DynamicsModel> model = DynamicsModel::Create(o);
    ASSERT_TRUE(model.ok());
    const Transitions d = MakeTransitions(60, 31);
    ASSERT_TRUE(
        model->AddSamples(d.x.topRows(45), d.u.topRows(45), d.next.topRows(45)).ok());
    ASSERT_TRUE(model->Refit().ok());
    ASSERT_TRUE(
        model->AddSamples(d.x.bottomRows(15), d.u.bottomRows(15), d.next.bottomRows(15))
            .ok());
    DynamicsModel copy = model->CopyData();
    EXPECT_FALSE(copy.fitted());
    EXPECT_EQ(copy.sample_count(), 60);
    EXPECT_EQ(copy.samples_since_fit(), 15);
    ASSERT_TRUE(model->Refit().ok());
    ASSERT_TRUE(copy.Refit().ok());
    EXPECT_EQ(copy.sparse(), sparse_above > 0);
    const Eigen::MatrixXd zt = Z(MakeTransitions(8, 32));
    Eigen::MatrixXd m1, v1, m2, v2;
    model->Predict(zt, &m1, &v1, nullptr, nullptr);
    copy.Predict(zt, &m2, &v2, nullptr, nullptr);
    EXPECT_EQ(m1, m2);
    EXPECT_EQ(v1, v2);
  }
}

// Sparse above sparse_above samples. With every sample an inducing point the
// sparse model is the exact one: same predictions and Jacobians in data units,
// also after samples appended past the Refit() move the prior mean.
TEST(DynamicsModelTest, SparseWithEverySampleInducingEqualsExact) {
  for (Target target : {Target::kDelta, Target::kNext}) {
    DynamicsModelOptions o = BaseOptions(target);
    o.fit_kernel = false;
    o.fixed = DataUnitHyperparameters();
    for (Hyperparameters& h : o.fixed) h.lengthscales *= 0.1;  // no sample redundant
    DynamicsModelOptions sparse_options = o;
    sparse_options.sparse_above = 20;
    sparse_options.sparse.max_inducing = 64;
    sparse_options.sparse.inducing_tolerance = 1e-10;
    absl::StatusOr<DynamicsModel> exact = DynamicsModel::Create(o);
    absl::StatusOr<DynamicsModel> sparse = DynamicsModel::Create(sparse_options);
    ASSERT_TRUE(exact.ok() && sparse.ok());
    const Transitions d = MakeTransitions(40, 21);
    for (DynamicsModel* m : {&*exact, &*sparse}) {
      ASSERT_TRUE(
          m->AddSamples(d.x.topRows(30), d.u.topRows(30), d.next.topRows(30)).ok());
      ASSERT_TRUE(m->Refit().ok());
      ASSERT_TRUE(
          m->AddSamples(d.x.bottomRows(10), d.u.bottomRows(10), d.next.bottomRows(10))
              .ok());
    }
    EXPECT_FALSE(exact->sparse());
    ASSERT_TRUE(sparse->sparse());
    EXPECT_EQ(sparse->inducing_counts(), std::vector<int>({40, 40}));
    EXPECT_EQ(sparse->PreparePoints(Z(d)), nullptr);  // no joint covariances
    const Eigen::MatrixXd zt = Z(MakeTransitions(6, 22));
    Eigen::MatrixXd m1, v1, m2, v2;
    std::vector<Eigen::MatrixXd> dm1, dv1, dm2, dv2;
    exact->Predict(zt, &m1, &v1, &dm1, &dv1);
    sparse->Predict(zt, &m2, &v2, &dm2, &dv2);
    EXPECT_LT((m1 - m2).cwiseAbs().maxCoeff(), 1e-8);
    EXPECT_LT((v1 - v2).cwiseAbs().maxCoeff(), 1e-8);
    for (int i = 0; i < 6; ++i) {
      EXPECT_LT((dm1[i] - dm2[i]).cwiseAbs().maxCoeff(), 1e-7);
      EXPECT_LT((dv1[i] - dv2[i]).cwiseAbs().maxCoeff(), 1e-7);
    }
  }
}

// Fitted: hyperparameters from a subset, sparse models on all samples; close to
// the exact model on the pendulum, and a restart (seed + rebuild) predicts the
// same.
TEST(DynamicsModelTest, SparseFitIsCloseToExactAndRebuildsTheSame) {
  DynamicsModelOptions o = BaseOptions(Target::kDelta);
  o.fit.seed = 3;
  DynamicsModelOptions sparse_options = o;
  sparse_options.sparse_above = 150;
  sparse_options.sparse_fit_samples = 150;  // hyperparameters from a subset
  absl::StatusOr<DynamicsModel> exact = DynamicsModel::Create(o);
  absl::StatusOr<DynamicsModel> sparse = DynamicsModel::Create(sparse_options);
  ASSERT_TRUE(exact.ok() && sparse.ok());
  const Transitions d = MakeTransitions(420, 23);
  for (DynamicsModel* m : {&*exact, &*sparse}) {
    ASSERT_TRUE(
        m->AddSamples(d.x.topRows(400), d.u.topRows(400), d.next.topRows(400)).ok());
    ASSERT_TRUE(m->Refit().ok());
    ASSERT_TRUE(
        m->AddSamples(d.x.bottomRows(20), d.u.bottomRows(20), d.next.bottomRows(20))
            .ok());
  }
  ASSERT_TRUE(sparse->sparse());
  // The angle's delta is nearly linear (long lengthscales): few points cover it.
  for (int count : sparse->inducing_counts()) {
    EXPECT_GE(count, 3);
    EXPECT_LT(count, 300);  // of 420
  }
  ASSERT_EQ(sparse->log_marginal_likelihoods().size(), 2u);
  const Transitions test = MakeTransitions(200, 24, 0.0);
  Eigen::MatrixXd m1, v1, m2, v2;
  exact->Predict(Z(test), &m1, &v1, nullptr, nullptr);
  sparse->Predict(Z(test), &m2, &v2, nullptr, nullptr);
  const double exact_rmse = std::sqrt((m1 - test.next).squaredNorm() / 200);
  const double sparse_rmse = std::sqrt((m2 - test.next).squaredNorm() / 200);
  EXPECT_LT(sparse_rmse, 1.1 * exact_rmse)
      << exact_rmse << " " << sparse->inducing_counts()[0] << " "
      << sparse->inducing_counts()[1];

  absl::StatusOr<DynamicsModel> restored = DynamicsModel::Create(sparse_options);
  ASSERT_TRUE(restored.ok());
  ASSERT_TRUE(restored->AddSamples(d.x, d.u, d.next).ok());
  ASSERT_TRUE(restored->SeedWarmStart(sparse->hyperparameters(), 400).ok());
  ASSERT_TRUE(restored->Rebuild().ok());
  EXPECT_TRUE(restored->sparse());
  EXPECT_EQ(restored->inducing_counts(), sparse->inducing_counts());
  Eigen::MatrixXd m3, v3;
  restored->Predict(Z(test), &m3, &v3, nullptr, nullptr);
  EXPECT_LT((m2 - m3).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((v2 - v3).cwiseAbs().maxCoeff(), 1e-9 * v2.cwiseAbs().maxCoeff());
}

// A fitted model that passes sparse_above in AddSamples (fixed hyperparameters, or
// between refits) turns sparse at once, keeps its refit schedule, and equals a model
// built from all the samples in one go (as after a restart).
TEST(DynamicsModelTest, PassingSparseAboveInAddSamplesSwitchesToSparse) {
  DynamicsModelOptions o = BaseOptions(Target::kDelta);
  o.fit_kernel = false;
  o.fixed = DataUnitHyperparameters();
  o.sparse_above = 30;
  absl::StatusOr<DynamicsModel> live = DynamicsModel::Create(o);
  absl::StatusOr<DynamicsModel> rebuilt = DynamicsModel::Create(o);
  ASSERT_TRUE(live.ok() && rebuilt.ok());
  const Transitions d = MakeTransitions(45, 25);
  ASSERT_TRUE(
      live->AddSamples(d.x.topRows(20), d.u.topRows(20), d.next.topRows(20)).ok());
  ASSERT_TRUE(live->Refit().ok());
  for (int i = 20; i < 45; ++i) {
    ASSERT_TRUE(live->AddSamples(d.x.row(i), d.u.row(i), d.next.row(i)).ok());
    EXPECT_EQ(live->sparse(), i + 1 > 30) << i;
  }
  EXPECT_EQ(live->samples_since_fit(), 25);
  ASSERT_TRUE(rebuilt->AddSamples(d.x, d.u, d.next).ok());
  ASSERT_TRUE(rebuilt->Refit().ok());
  ASSERT_TRUE(rebuilt->sparse());
  EXPECT_EQ(live->inducing_counts(), rebuilt->inducing_counts());
  const std::vector<double> lml = live->log_marginal_likelihoods();
  ASSERT_EQ(lml.size(), 2u);
  for (double v : lml) EXPECT_TRUE(std::isfinite(v));
  const Eigen::MatrixXd zt = Z(MakeTransitions(8, 26));
  Eigen::MatrixXd m1, v1, m2, v2;
  live->Predict(zt, &m1, &v1, nullptr, nullptr);
  rebuilt->Predict(zt, &m2, &v2, nullptr, nullptr);
  EXPECT_LT((m1 - m2).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((v1 - v2).cwiseAbs().maxCoeff(), 1e-9);
}

// A stopped Refit() leaves a usable model with the best hyperparameters so far
// and keeps the refit due; the next Refit() continues and does not end lower.
TEST(DynamicsModelTest, StoppedRefitIsUsableAndStaysDue) {
  DynamicsModelOptions o = BaseOptions(Target::kDelta);
  o.fit_threads = 1;  // count the stop calls deterministically
  absl::StatusOr<DynamicsModel> m = DynamicsModel::Create(o);
  ASSERT_TRUE(m.ok());
  const Transitions d = MakeTransitions(120, 8);
  ASSERT_TRUE(m->AddSamples(d.x, d.u, d.next).ok());
  int calls = 0;
  const absl::StatusOr<FitSummary> stopped = m->Refit([&calls]() { return ++calls > 3; });
  ASSERT_TRUE(stopped.ok()) << stopped.status();
  EXPECT_TRUE(stopped->stopped);
  EXPECT_TRUE(m->fitted());
  EXPECT_EQ(m->samples_since_fit(), 120);  // still due
  Eigen::MatrixXd mean, var;
  m->Predict(Z(d).topRows(5), &mean, &var, nullptr, nullptr);
  EXPECT_TRUE(mean.allFinite() && var.allFinite());
  const std::vector<double> lml_stopped = m->log_marginal_likelihoods();

  const absl::StatusOr<FitSummary> resumed = m->Refit();
  ASSERT_TRUE(resumed.ok()) << resumed.status();
  EXPECT_FALSE(resumed->stopped);
  EXPECT_EQ(m->samples_since_fit(), 0);
  const std::vector<double> lml = m->log_marginal_likelihoods();
  ASSERT_EQ(lml.size(), lml_stopped.size());
  for (size_t j = 0; j < lml.size(); ++j) EXPECT_GE(lml[j], lml_stopped[j] - 1e-9);
}

// Scaling the state by 4 (exact in binary) scales the data-unit hyperparameters
// (lengthscales of the state inputs, variances) and leaves normalised ones alone.
TEST(DynamicsModelTest, HyperparametersAreInDataUnits) {
  const Transitions d = MakeTransitions(50, 8);
  DynamicsModelOptions o = BaseOptions(Target::kDelta);
  DynamicsModelOptions o4 = o;
  o4.input_half_width.head(2) *= 4.0;
  o4.measurement_noise_variance *= 16.0;
  absl::StatusOr<DynamicsModel> m = DynamicsModel::Create(o);
  absl::StatusOr<DynamicsModel> m4 = DynamicsModel::Create(o4);
  ASSERT_TRUE(m.ok() && m4.ok());
  ASSERT_TRUE(m->AddSamples(d.x, d.u, d.next).ok());
  ASSERT_TRUE(m4->AddSamples(4.0 * d.x, d.u, 4.0 * d.next).ok());
  ASSERT_TRUE(m->Refit().ok());
  ASSERT_TRUE(m4->Refit().ok());
  for (int j = 0; j < 2; ++j) {
    const Hyperparameters h = m->hyperparameters()[j];
    const Hyperparameters h4 = m4->hyperparameters()[j];
    EXPECT_LT(RelErr(h4.signal_variance, 16.0 * h.signal_variance), 1e-9);
    EXPECT_LT(RelErr(h4.noise_variance, 16.0 * h.noise_variance), 1e-9);
    EXPECT_LT(RelErr(h4.lengthscales(0), 4.0 * h.lengthscales(0)), 1e-9);
    EXPECT_LT(RelErr(h4.lengthscales(1), 4.0 * h.lengthscales(1)), 1e-9);
    EXPECT_LT(RelErr(h4.lengthscales(2), h.lengthscales(2)), 1e-9);
  }
}

TEST(DynamicsModelTest, InvalidInputAddsNothing) {
  absl::StatusOr<DynamicsModel> model =
      DynamicsModel::Create(BaseOptions(Target::kDelta));
  ASSERT_TRUE(model.ok());
  const Transitions d = MakeTransitions(5, 9);
  EXPECT_EQ(model->AddSamples(d.x, d.u, d.next.leftCols(1)).code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(model->AddSamples(d.x.topRows(4), d.u, d.next).code(),
            absl::StatusCode::kInvalidArgument);
  Eigen::MatrixXd bad = d.u;
  bad(2, 0) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(model->AddSamples(d.x, bad, d.next).code(),
            absl::StatusCode::kInvalidArgument);
  bad = d.next;
  bad(0, 1) = std::numeric_limits<double>::infinity();
  EXPECT_EQ(model->AddSamples(d.x, d.u, bad).code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(model->sample_count(), 0);
  // Fewer than 2 samples: no fit. Predict before a fit is a precondition
  // violation, reported as NaN.
  ASSERT_TRUE(model->AddSamples(d.x.topRows(1), d.u.topRows(1), d.next.topRows(1)).ok());
  EXPECT_EQ(model->Refit().status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_FALSE(model->fitted());
  Eigen::MatrixXd mean, var;
  model->Predict(Z(d), &mean, &var, nullptr, nullptr);
  EXPECT_EQ(mean.rows(), 5);
  EXPECT_TRUE(mean.array().isNaN().all());
  // After a fit, bad samples still add nothing.
  ASSERT_TRUE(model->AddSamples(d.x, d.u, d.next).ok());
  ASSERT_TRUE(model->Refit().ok());
  EXPECT_EQ(model->AddSamples(d.x, bad, d.next).code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(model->sample_count(), 6);
  EXPECT_EQ(model->samples_since_fit(), 0);
  // Bad options.
  DynamicsModelOptions o = BaseOptions(Target::kDelta);
  o.measurement_noise_variance = 0.0;
  EXPECT_EQ(DynamicsModel::Create(o).status().code(), absl::StatusCode::kInvalidArgument);
  o = BaseOptions(Target::kDelta);
  o.input_half_width = Eigen::Vector2d(1.0, 1.0);
  EXPECT_EQ(DynamicsModel::Create(o).status().code(), absl::StatusCode::kInvalidArgument);
  o = BaseOptions(Target::kDelta);
  o.fit_kernel = false;
  EXPECT_EQ(DynamicsModel::Create(o).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(DynamicsModelTest, IllConditionedDataGivesFinitePredictions) {
  DynamicsModelOptions o = BaseOptions(Target::kDelta);
  o.measurement_noise_variance = 1e-12;
  o.input_center.setConstant(std::numeric_limits<double>::quiet_NaN());
  o.input_half_width.setConstant(std::numeric_limits<double>::quiet_NaN());
  absl::StatusOr<DynamicsModel> model = DynamicsModel::Create(o);
  ASSERT_TRUE(model.ok());
  const Transitions d = MakeTransitions(4, 10, 0.0);
  for (int k = 0; k < 25; ++k) ASSERT_TRUE(model->AddSamples(d.x, d.u, d.next).ok());
  ASSERT_TRUE(model->Refit().ok());
  ASSERT_TRUE(model->AddSamples(d.x, d.u, d.next).ok());  // row appends of duplicates
  Eigen::MatrixXd z(6, 3);
  z << Z(d), Z(MakeTransitions(2, 11));
  Eigen::MatrixXd mean, var;
  std::vector<Eigen::MatrixXd> dm, dv;
  model->Predict(z, &mean, &var, &dm, &dv);
  EXPECT_TRUE(mean.allFinite());
  EXPECT_TRUE(var.allFinite());
  for (int i = 0; i < 6; ++i) EXPECT_TRUE(dm[i].allFinite() && dv[i].allFinite());
  // Same with a constant input (half-width from data hits its floor).
  DynamicsModelOptions oc = o;
  absl::StatusOr<DynamicsModel> constant = DynamicsModel::Create(oc);
  ASSERT_TRUE(constant.ok());
  Eigen::MatrixXd x = d.x, u = Eigen::MatrixXd::Zero(4, 1), next = d.next;
  ASSERT_TRUE(constant->AddSamples(x, u, next).ok());
  ASSERT_TRUE(constant->AddSamples(x, u, next).ok());
  ASSERT_TRUE(constant->Refit().ok());
  constant->Predict(z, &mean, &var, nullptr, nullptr);
  EXPECT_TRUE(mean.allFinite());
  EXPECT_TRUE(var.allFinite());
}

}  // namespace
}  // namespace excite::gp
