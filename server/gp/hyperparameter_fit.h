#ifndef EXCITE_SERVER_GP_HYPERPARAMETER_FIT_H_
#define EXCITE_SERVER_GP_HYPERPARAMETER_FIT_H_

#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "absl/status/statusor.h"
#include "server/gp/hyperparameters.h"

namespace excite::gp {

class GpModel;

// Options of the ML-II fit (L-BFGS-B on log-parameters), on normalised data
// (inputs scaled by the half-width of their range, outputs standardised).
//
// Defaults, chosen for the receding-horizon loop which refits after every sample
// (pendulum, n = 300, z_dim = 3, 2 outputs: see bench/gp; one objective
// evaluation there is an O(n^3) factorisation + gradient, ~3-4 ms on this
// machine, so the budget is about 10 evaluations per output and refit):
// - A cold fit (no previous optimum) uses the data-driven default start plus
//   `restarts` random starts: it happens once, usually at small n.
// - A warm fit uses the previous optimum (clamped) and `warm_restarts` (0) random
//   starts: the optimum moves little from one sample to the next, so it converges
//   in a handful of evaluations. The data-driven default start, which keeps the
//   fit from staying in a flat "everything is noise" optimum, is added whenever
//   `warm_default_start` is set; DynamicsModel sets it when the sample count has
//   grown by `default_start_growth` since the default start last ran (20%: at
//   n = 300 once every 50 refits), which bounds its amortised cost.
// - Tolerances are on the LML per sample: 1e-6 of it is negligible.
struct FitOptions {
  double min_lengthscale = 0.05;
  double max_lengthscale = 50.0;
  double min_signal_variance = 1e-2;
  double max_signal_variance = 1e2;
  // Bounds of a fitted noise variance (normalised units). The lower bound is
  // max(floor given to the fit, min_noise_variance): the latter is a numerical
  // guard (condition number of K); the upper bound is
  // max(max_noise_variance, 10 * floor).
  double min_noise_variance = 1e-6;
  double max_noise_variance = 10.0;
  // Random restarts (log-uniform within the bounds) on top of the data-driven
  // default start, when there is no warm start.
  int restarts = 2;
  // Random restarts when a warm start is available.
  int warm_restarts = 0;
  // With a warm start, also run the data-driven default start.
  bool warm_default_start = true;
  // DynamicsModel: run the default start at a warm Refit() when the sample count
  // is >= default_start_growth times that at the last Refit() which ran it
  // (1 or less: at every Refit()).
  double default_start_growth = 1.2;
  // Cold fits with more than 2 * presearch_size samples (0: never) run the
  // default and random starts on a random subset of presearch_size samples, then
  // polish only the best of them on all the data: an evaluation on the subset
  // costs (presearch_size / n)^3 of one on all of it.
  int presearch_size = 256;
  // A cold fit whose best point has lengthscales above reactivate_above (0: never)
  // runs one more start from it with those at 1 (hyperparameter_fit.cc says why).
  double reactivate_above = 5.0;
  // L-BFGS-B iterations per start.
  int max_iterations = 60;
  // The objective is -LML / max(1, n) (scale-free). A start stops when its
  // projected gradient (max-norm, log-parameters) is below gradient_tolerance or
  // when the objective changed by less than
  // function_tolerance * max(1, |objective|) over one iteration.
  double gradient_tolerance = 1e-4;
  double function_tolerance = 1e-6;
  uint64_t seed = 0;
};

// What a fit did, summed over outputs.
struct FitSummary {
  bool fitted = false;  // false if hyperparameters are fixed (only refactorised)
  int starts = 0;
  int iterations = 0;     // L-BFGS-B iterations (evaluations for a failed start)
  int failed_starts = 0;  // line-search failures; their best iterate is kept
  double wall_time_ms = 0.0;
  // Added: objective evaluations (each an O(n^3) factorisation + gradient).
  int evaluations = 0;
  // Of which on the presearch subset (FitOptions::presearch_size).
  int presearch_evaluations = 0;
  // The stop callback ended the fit early; the model holds the best point seen.
  bool stopped = false;
};

// Which hyperparameters a fit left at a bound of `options` (normalised units,
// within 1 % in log scale): the data did not pin them; the fit would have gone
// further.
struct BoundHits {
  std::vector<int> lengthscales;  // indices into Hyperparameters::lengthscales
  bool signal_variance = false;
};
BoundHits HitBounds(const Hyperparameters& normalised, const FitOptions& options);

// Polled before every objective evaluation (each O(n^3)); true ends the fit.
// May be called from several threads at once (DynamicsModel fits outputs in
// parallel).
using FitStopFn = std::function<bool()>;

// Fits the hyperparameters of `model` (which holds the normalised data) by
// maximising the log marginal likelihood with L-BFGS-B on log-parameters, from
// the starts described at FitOptions (warm start first, then the default start
// if there is no warm start or options.warm_default_start, then random starts). If
// `fit_noise`, the noise variance is fitted within [max(noise_variance,
// min_noise_variance), upper bound]; otherwise it is fixed at `noise_variance` and left
// out of the optimisation vector. `warm_start` (if any) is clamped into the bounds. On
// return the model is factorised with the best hyperparameters found. Deterministic for a
// given options.seed. If `stop` returns true the remaining evaluations and starts are
// skipped and the best point seen so far is kept (summary.stopped; the warm start
// if nothing was evaluated). INVALID_ARGUMENT on bad options or an empty model.
absl::StatusOr<FitSummary> FitHyperparameters(
    const FitOptions& options, double noise_variance, bool fit_noise,
    const std::optional<Hyperparameters>& warm_start, GpModel* model,
    const FitStopFn& stop = nullptr);

}  // namespace excite::gp

#endif  // EXCITE_SERVER_GP_HYPERPARAMETER_FIT_H_
