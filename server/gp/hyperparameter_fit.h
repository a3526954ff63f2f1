#ifndef EXCITE_SERVER_GP_HYPERPARAMETER_FIT_H_
#define EXCITE_SERVER_GP_HYPERPARAMETER_FIT_H_

#include <cstdint>

namespace excite::gp {

// Options of the ML-II fit (L-BFGS-B on log-parameters), on normalised data.
struct FitOptions {
  double min_lengthscale = 0.05;
  double max_lengthscale = 50.0;
  double min_signal_variance = 1e-2;
  double max_signal_variance = 1e2;
  // Random restarts (log-uniform within the bounds) on top of the warm start and
  // the data-driven default start.
  int restarts = 2;
  // L-BFGS-B iterations per start.
  int max_iterations = 60;
  uint64_t seed = 0;
};

// What a fit did, summed over outputs.
struct FitSummary {
  bool fitted = false;  // false if hyperparameters are fixed (only refactorised)
  int starts = 0;
  int iterations = 0;
  int failed_starts = 0;  // line-search failures; their best iterate is kept
  double wall_time_ms = 0.0;
};

}  // namespace excite::gp

#endif  // EXCITE_SERVER_GP_HYPERPARAMETER_FIT_H_
