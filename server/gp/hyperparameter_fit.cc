#include "server/gp/hyperparameter_fit.h"

#include <LBFGSB.h>

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <limits>
#include <numeric>
#include <optional>
#include <random>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "server/gp/gp_model.h"
#include "server/gp/hyperparameters.h"

namespace excite::gp {
namespace {

// Thrown by the objective when the stop callback fires; unlike a line-search
// failure (std::exception) it ends the whole fit.
struct FitStopped {};

bool SameTheta(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  return a.size() == b.size() && a == b;
}

// Parameter vector: (log sf2, log l_1..d[, log sn2]).
class Objective {
 public:
  Objective(GpModel* model, int dim, bool fit_noise, double fixed_noise,
            const FitStopFn& stop)
      : model_(model),
        dim_(dim),
        fit_noise_(fit_noise),
        fixed_noise_(fixed_noise),
        stop_(stop) {}

  Hyperparameters Unpack(const Eigen::VectorXd& theta) const {
    Hyperparameters h;
    h.signal_variance = std::exp(theta(0));
    h.lengthscales = theta.segment(1, dim_).array().exp();
    h.noise_variance = fit_noise_ ? std::exp(theta(dim_ + 1)) : fixed_noise_;
    return h;
  }

  // -LML / n and its gradient; remembers the best point seen in this start.
  double operator()(const Eigen::VectorXd& theta, Eigen::VectorXd& grad) {
    if (stop_ && stop_()) throw FitStopped{};
    ++evaluations_;
    const double scale = 1.0 / std::max(1, model_->size());
    grad.setZero(theta.size());
    if (!SameTheta(theta, factorised_theta_)) {
      factorised_theta_.resize(0);
      if (!theta.allFinite() || !model_->SetHyperparameters(Unpack(theta)).ok()) {
        return std::numeric_limits<double>::max();
      }
      factorised_theta_ = theta;
    }
    const double f = -scale * model_->log_marginal_likelihood();
    const Eigen::VectorXd g = model_->LogMarginalLikelihoodGradient();
    grad = -scale * g.head(theta.size());
    if (!std::isfinite(f) || !grad.allFinite()) {
      grad.setZero();
      return std::numeric_limits<double>::max();
    }
    if (f < best_f_) {
      best_f_ = f;
      best_theta_ = theta;
    }
    return f;
  }

  void ResetBest() {
    best_f_ = std::numeric_limits<double>::infinity();
    best_theta_.resize(0);
  }
  double best_f() const { return best_f_; }
  const Eigen::VectorXd& best_theta() const { return best_theta_; }
  int evaluations() const { return evaluations_; }
  // The point at which the model is currently factorised (empty if unknown).
  const Eigen::VectorXd& factorised_theta() const { return factorised_theta_; }
  // The model is factorised at `theta` already: an evaluation there reuses it.
  void AssumeFactorisedAt(Eigen::VectorXd theta) { factorised_theta_ = std::move(theta); }

 private:
  GpModel* model_;
  int dim_;
  bool fit_noise_;
  double fixed_noise_;
  const FitStopFn& stop_;
  int evaluations_ = 0;
  double best_f_ = std::numeric_limits<double>::infinity();
  Eigen::VectorXd best_theta_;
  Eigen::VectorXd factorised_theta_;
};

absl::Status CheckOptions(const FitOptions& o) {
  auto bounded = [](double lo, double hi) {
    return std::isfinite(lo) && std::isfinite(hi) && lo > 0.0 && lo <= hi;
  };
  if (!bounded(o.min_lengthscale, o.max_lengthscale) ||
      !bounded(o.min_signal_variance, o.max_signal_variance) ||
      !bounded(o.min_noise_variance, o.max_noise_variance)) {
    return absl::InvalidArgumentError("FitOptions: bounds must satisfy 0 < min <= max");
  }
  if (o.restarts < 0 || o.warm_restarts < 0 || o.max_iterations < 1) {
    return absl::InvalidArgumentError(
        "FitOptions: restarts >= 0, warm_restarts >= 0, max_iterations >= 1");
  }
  if (!(o.gradient_tolerance >= 0.0) || !(o.function_tolerance >= 0.0) ||
      !std::isfinite(o.default_start_growth)) {
    return absl::InvalidArgumentError(
        "FitOptions: tolerances must be >= 0 and default_start_growth finite");
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<FitSummary> FitHyperparameters(
    const FitOptions& options, double noise_variance, bool fit_noise,
    const std::optional<Hyperparameters>& warm_start, GpModel* model,
    const FitStopFn& stop) {
  const auto t0 = std::chrono::steady_clock::now();
  if (absl::Status s = CheckOptions(options); !s.ok()) return s;
  if (model == nullptr || model->size() == 0) {
    return absl::InvalidArgumentError("FitHyperparameters needs a model with data");
  }
  if (!(std::isfinite(noise_variance) && noise_variance > 0.0)) {
    return absl::InvalidArgumentError("noise variance must be finite and positive");
  }
  const int d = model->dim();
  if (warm_start.has_value() && warm_start->lengthscales.size() != d) {
    return absl::InvalidArgumentError("warm start has the wrong number of lengthscales");
  }
  const double noise_lo = std::max(noise_variance, options.min_noise_variance);
  const double noise_hi = std::max(options.max_noise_variance, 10.0 * noise_lo);
  const int p = d + (fit_noise ? 2 : 1);

  Eigen::VectorXd lb(p), ub(p);
  lb(0) = std::log(options.min_signal_variance);
  ub(0) = std::log(options.max_signal_variance);
  lb.segment(1, d).setConstant(std::log(options.min_lengthscale));
  ub.segment(1, d).setConstant(std::log(options.max_lengthscale));
  if (fit_noise) {
    lb(d + 1) = std::log(noise_lo);
    ub(d + 1) = std::log(noise_hi);
  }
  auto pack = [&](const Hyperparameters& h) {
    Eigen::VectorXd theta(p);
    theta(0) = std::log(h.signal_variance);
    theta.segment(1, d) = h.lengthscales.array().log();
    if (fit_noise) theta(d + 1) = std::log(h.noise_variance);
    // Clamp into the bounds (non-finite entries go to the middle).
    for (int i = 0; i < p; ++i) {
      theta(i) = std::isfinite(theta(i)) ? std::clamp(theta(i), lb(i), ub(i))
                                         : 0.5 * (lb(i) + ub(i));
    }
    return theta;
  };

  // Presearch: a cold fit on a subset picks the one start polished on all data.
  FitSummary summary;
  std::optional<Hyperparameters> presearch_optimum;
  if (!warm_start.has_value() && options.presearch_size > 0 &&
      model->size() > 2 * options.presearch_size) {
    std::vector<int> rows(model->size());
    std::iota(rows.begin(), rows.end(), 0);
    std::mt19937_64 shuffle_rng(options.seed ^ 0x9e3779b97f4a7c15ULL);
    std::shuffle(rows.begin(), rows.end(), shuffle_rng);
    rows.resize(options.presearch_size);
    std::sort(rows.begin(), rows.end());
    GpModel subset;
    if (absl::Status s = subset.Reset(model->inputs()(rows, Eigen::all),
                                      model->targets()(rows), model->hyperparameters());
        !s.ok()) {
      return s;
    }
    FitOptions subset_options = options;
    subset_options.presearch_size = 0;
    absl::StatusOr<FitSummary> r = FitHyperparameters(
        subset_options, noise_variance, fit_noise, std::nullopt, &subset, stop);
    if (!r.ok()) return r.status();
    summary.starts += r->starts;
    summary.iterations += r->iterations;
    summary.failed_starts += r->failed_starts;
    summary.presearch_evaluations = r->evaluations;
    summary.stopped = r->stopped;
    presearch_optimum = subset.hyperparameters();
  }

  // Starts: warm (if any), data-driven default, random log-uniform; or the
  // presearch's optimum alone.
  std::vector<Eigen::VectorXd> starts;
  if (presearch_optimum.has_value()) starts.push_back(pack(*presearch_optimum));
  if (warm_start.has_value()) starts.push_back(pack(*warm_start));
  if (!presearch_optimum.has_value() &&
      (!warm_start.has_value() || options.warm_default_start)) {
    // Outputs are standardised and inputs scaled to about [-1, 1]: unit signal
    // variance and lengthscales, and a noise well below the signal.
    Hyperparameters h;
    h.signal_variance = 1.0;
    h.lengthscales = Eigen::VectorXd::Ones(d);
    h.noise_variance = std::max(noise_lo, 1e-2);
    starts.push_back(pack(h));
  }
  std::mt19937_64 rng(options.seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const int random_starts = presearch_optimum.has_value() ? 0
                            : warm_start.has_value()      ? options.warm_restarts
                                                          : options.restarts;
  for (int r = 0; r < random_starts; ++r) {
    Eigen::VectorXd theta(p);
    for (int i = 0; i < p; ++i) theta(i) = lb(i) + unit(rng) * (ub(i) - lb(i));
    starts.push_back(theta);
  }

  LBFGSpp::LBFGSBParam<double> param;
  param.m = 6;
  param.max_iterations = options.max_iterations;
  param.epsilon = options.gradient_tolerance;
  param.epsilon_rel = 0.0;
  param.past = 1;
  param.delta = options.function_tolerance;
  LBFGSpp::LBFGSBSolver<double> solver(param);

  Objective objective(model, d, fit_noise, noise_variance, stop);
  {
    // The caller resets the model at its warm start (DynamicsModel) or the default
    // start: evaluating there again would repeat an O(n^3) factorisation.
    const Hyperparameters& h = model->hyperparameters();
    Eigen::VectorXd at(p);
    at(0) = std::log(h.signal_variance);
    at.segment(1, d) = h.lengthscales.array().log();
    if (fit_noise) at(d + 1) = std::log(h.noise_variance);
    if (fit_noise || h.noise_variance == noise_variance) {
      objective.AssumeFactorisedAt(std::move(at));
    }
  }
  summary.fitted = true;
  double best_f = std::numeric_limits<double>::infinity();
  Eigen::VectorXd best_theta;
  auto run = [&](const Eigen::VectorXd& start) {
    ++summary.starts;
    objective.ResetBest();
    Eigen::VectorXd theta = start;
    double f = 0.0;
    const int evaluations_before = objective.evaluations();
    try {
      summary.iterations += solver.minimize(objective, theta, f, lb, ub);
    } catch (const FitStopped&) {
      summary.stopped = true;
      summary.iterations += objective.evaluations() - evaluations_before;
    } catch (const std::exception&) {
      // Line-search failure: the functor kept the best iterate of this start.
      ++summary.failed_starts;
      summary.iterations += objective.evaluations() - evaluations_before;
    }
    if (objective.best_f() < best_f) {
      best_f = objective.best_f();
      best_theta = objective.best_theta();
    }
  };
  for (const Eigen::VectorXd& start : starts) {
    if (summary.stopped) break;
    run(start);
  }
  // Reactivation (cold fits): ARD can park a relevant input at a long lengthscale,
  // where the LML is flat, and stop there; one more start from the best point with
  // those inputs back at lengthscale 1 lets them in again (a truly irrelevant input
  // goes back out). After a presearch it runs in the subset's fit and again here,
  // on all data: 256 samples of 24 inputs missed small effects at n = 2000.
  if (!warm_start.has_value() && options.reactivate_above > 0.0 &&
      best_theta.size() == p && !summary.stopped) {
    Eigen::VectorXd start = best_theta;
    bool parked = false;
    for (int i = 1; i <= d; ++i) {
      if (start(i) > std::log(options.reactivate_above)) {
        start(i) = std::clamp(0.0, lb(i), ub(i));
        parked = true;
      }
    }
    // ... and with a tenth of the fitted noise, which had absorbed their effect.
    if (fit_noise) start(d + 1) = std::max(lb(d + 1), start(d + 1) - std::log(10.0));
    if (parked) run(start);
  }
  summary.evaluations = summary.presearch_evaluations + objective.evaluations();
  absl::Status status;
  if (best_theta.size() == p) {
    // Refactorise at the best point unless the model is already there.
    if (!SameTheta(objective.factorised_theta(), best_theta)) {
      status = model->SetHyperparameters(objective.Unpack(best_theta));
    }
  } else {
    // Every evaluation failed (or none ran before a stop): fall back to the first
    // start, the warm start if there is one.
    status = model->SetHyperparameters(objective.Unpack(starts.front()));
  }
  if (!status.ok()) return status;
  summary.wall_time_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
          .count();
  return summary;
}

BoundHits HitBounds(const Hyperparameters& normalised, const FitOptions& options) {
  const auto at_bound = [](double value, double lower, double upper) {
    return std::abs(std::log(value / lower)) < 0.01 ||
           std::abs(std::log(value / upper)) < 0.01;
  };
  BoundHits hits;
  for (Eigen::Index i = 0; i < normalised.lengthscales.size(); ++i) {
    if (at_bound(normalised.lengthscales(i), options.min_lengthscale,
                 options.max_lengthscale)) {
      hits.lengthscales.push_back(static_cast<int>(i));
    }
  }
  hits.signal_variance = at_bound(normalised.signal_variance, options.min_signal_variance,
                                  options.max_signal_variance);
  return hits;
}

}  // namespace excite::gp
