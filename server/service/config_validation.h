#ifndef EXCITE_SERVER_SERVICE_CONFIG_VALIDATION_H_
#define EXCITE_SERVER_SERVICE_CONFIG_VALIDATION_H_

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "excite/v1/session_config.pb.h"

namespace excite::service {

// Caps of a session's size (beyond them a GP session is not useful on one node).
inline constexpr int kMaxStateDim = 64;
inline constexpr int kMaxInputDim = 32;
inline constexpr int kMaxHorizon = 200;
// Largest safety.margin (standard deviations).
inline constexpr double kMaxSafetyMargin = 10.0;
// Caps of the ML-II fit's work per refit (restarts x iterations x O(n^3)).
inline constexpr int kMaxFitRestarts = 20;
inline constexpr int kMaxFitIterations = 1000;

// Defaults the proto documents that have no home in the engine's option structs.
inline constexpr double kDefaultTimeBudgetS = 10.0;  // planner.time_budget_s
inline constexpr int kDefaultRefitEverySamples = 1;  // refit.every_samples
// refit.growth: the amortised refit stays under a tenth of a pendulum rec step at
// any n (bench/plan BM_RecStepAtSize: a warm refit at n = 500 costs about one plan,
// and refit / plan grows as n, which growth * n refits apart cancels).
inline constexpr double kDefaultRefitGrowth = 0.05;
inline constexpr int kDefaultMinSamples = 2;  // refit.min_samples
// sparse.above_samples: the largest measured size at which the exact GP's rec step
// on the pendulum stays under the 200 ms step target (bench/plan BM_RecStepAtSize:
// 116-131 ms p50 at n = 1000, 323-390 ms at 2000). Not earlier: an exploration that
// switched at 300 learned worse than the exact GP (README, "Sparse GP for long
// sessions").
inline constexpr int kDefaultSparseAboveSamples = 1000;
inline constexpr int kMinSparseAboveSamples = 10;
inline constexpr int kMaxSparseAboveSamples = 1000000;
inline constexpr int kMaxInducingPoints = 4096;
inline constexpr int kMaxSparseFitSamples = 100000;

// Validates a SessionConfig, wherever it comes from (CreateSession on the wire or a
// textproto file), and fills the defaults in place so that the stored config says
// what the server does. Returns INVALID_ARGUMENT naming the exact field path under
// `path`, e.g. "config.input_bounds[0]: lower (2) must be < upper (1)". On error
// `config` may be partly filled.
//
// Rules (a zero/unset number means "default" where a default is listed; the
// defaults are those of gp::FitOptions and plan::PlanOptions, as the proto says;
// the numeric ranges are value_ranges.h's, chosen so that the model stays finite):
//   state_dim in [1, 64]; input_dim in [1, 32];
//   input_bounds: exactly input_dim intervals, lower < upper, both within
//     +-1e30, upper - lower >= 1e-30;
//   state_bounds: 0 or state_dim intervals, as input_bounds;
//   noise.variance in [1e-30, 1e30]; noise.fit only with kernel.fit;
//   kernel.fit = false: kernel.fixed has state_dim entries (ValidateHyperparameters);
//     kernel.fit = true: kernel.fixed empty;
//   kernel.lengthscale_bounds default [0.05, 50], within [1e-6, 1e6];
//     signal_variance_bounds default [0.01, 100], within [1e-12, 1e12]; lower < upper;
//   kernel.restarts in [0, 20] (0: default 2); kernel.max_iterations in
//     [0, 1000] (0: default 60);
//   target: UNSPECIFIED -> DELTA; strategy: UNSPECIFIED -> REC; unknown values are
//     rejected; STRATEGY_SEP and STRATEGY_ROI require state_dim state_bounds;
//   horizon in [0, 200] (0: default 15); GREEDY forces 1;
//   refit.every_samples in [0, 1000000] (0: default 1); refit.growth finite in
//     [0, 10] (unset: 0.05); refit.min_samples in
//     {0} or [2, 1000000] (0: default 2; a fit needs 2 samples);
//   planner.max_iterations in [0, 10000] (0: default 100); planner.restarts in
//     [0, 100] (0: default 1); planner.tolerance 0 (default 1e-4) or finite in
//     (0, 1); planner.time_budget_s 0 (default 10) or in [0.001, 3600];
//   signal (plan::SignalOptions defaults): prbs_min_hold, chirp_period and
//     random_hold in [1, 1000000] (0: default 5, 200, 1); chirp_start_frequency
//     and chirp_end_frequency finite in (0, 0.5] (0: default 0.01, 0.2);
//   sep (plan::SepOptions defaults): search_starts in [1, 100] (0: default 4),
//     search_samples in [1, 100000] (0: default 256), search_iterations in
//     [1, 10000] (0: default 50);
//   roi: reference_points in [1, 4096] (0: default 256);
//   safety: state_bounds 0 or state_dim intervals, as state_bounds; margin
//     finite in [0, kMaxSafetyMargin] (unset with a box: 2).
//   sparse: above_samples 0 or in [10, 1000000] (unset: 1000; MI and ROI: unset
//     or 0, filled in as 0); max_inducing in [0, 4096] (0: default 256);
//     inducing_tolerance 0 (default 0.1) or finite in [1e-6, 1e6]; fit_samples in
//     [10, 100000] (0: default 1000); the last three filled in only when
//     above_samples > 0.
//   signal, sep and roi fields that are set are checked whatever the strategy, but
//   defaults are filled in only for the fields the session's strategy uses (prbs:
//   prbs_min_hold; chirp: the chirp_* fields; random: random_hold; sep: all of
//   sep; roi: all of roi), so other sessions' stored configs do not change.
// Note that proto3 cannot tell 0 from unset: 0 restarts cannot be requested.
absl::Status ValidateSessionConfig(v1::SessionConfig* config,
                                   absl::string_view path = "config");

// One output's hyperparameters in data units (kernel.fixed[i], or the saved ones
// of a SessionArchive): signal_variance and noise_variance in [1e-100, 1e100],
// `z_dim` (state_dim + input_dim) lengthscales in [1e-50, 1e50] (wide enough for
// every fit the server makes, value_ranges.h). INVALID_ARGUMENT naming
// the field under `path`, e.g. "config.kernel.fixed[1].lengthscales[2]".
absl::Status ValidateHyperparameters(absl::string_view path,
                                     const v1::Hyperparameters& hyperparameters,
                                     int z_dim);

// Convenience: a validated copy with defaults filled.
absl::StatusOr<v1::SessionConfig> ValidatedSessionConfig(
    const v1::SessionConfig& config, absl::string_view path = "config");

}  // namespace excite::service

#endif  // EXCITE_SERVER_SERVICE_CONFIG_VALIDATION_H_
