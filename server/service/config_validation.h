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
// The numbers whose 0 means a default (iterations, restarts, horizon, refit
// counts, signal, sep, roi, sparse sizes, planner tolerances and budget) are
// checked and filled from one table, config_rules.h (its rows are the API
// reference's "SessionConfig numbers"). The rules written here relate fields or
// depend on presence:
//   state_dim in [1, 64]; input_dim in [1, 32];
//   input_bounds: exactly input_dim intervals, lower < upper, both within
//     +-1e30, upper - lower >= 1e-30; state_bounds: 0 or state_dim of them;
//   noise.variance in [1e-30, 1e30]; noise.fit only with kernel.fit;
//   kernel.fit unset: fitted unless kernel.fixed is given; kernel.fit = false:
//     state_dim kernel.fixed entries (ValidateHyperparameters), true: none;
//   kernel.lengthscale_bounds (default [0.05, 50]) within [1e-6, 1e6],
//     signal_variance_bounds (default [0.01, 100]) within [1e-12, 1e12];
//   target UNSPECIFIED -> DELTA; strategy UNSPECIFIED -> REC; unknown values
//     are rejected; a strategy that needs state bounds (plan/strategy.h) needs
//     state_dim of them; a fixed horizon (greedy: 1) overrides a valid one;
//   refit.growth finite in [0, 10] (unset: 0.05);
//   optimistic.beta in (0, 10] when set (filled in, 1, for optimistic);
//   auto.chooser for STRATEGY_AUTO: UNSPECIFIED -> PORTFOLIO; auto.members: each
//     once, none of pa, sep, auto (empty: the chooser's
//     plan::DefaultAutoMembers filled in); the members' needs (state bounds,
//     joint covariances) and config defaults apply as for the strategy alone,
//     and the portfolio's criterion's (roi's; mi's without state bounds);
//   safety: 0 or state_dim state_bounds; margin finite in [0, 10] (unset with
//     a box: 2);
//   sparse.above_samples 0 or in [10, 1000000] (unset: 1000; strategies that
//     need joint covariances: 0); inducing_tolerance 0 (default 0.1) or in
//     [1e-6, 1e6], filled in only when above_samples > 0.
// Note that proto3 cannot tell 0 from unset: 0 restarts cannot be requested.
absl::Status ValidateSessionConfig(v1::SessionConfig* config,
                                   absl::string_view path = "config");

// One output's hyperparameters in data units (kernel.fixed[i], or the saved ones
// of a SessionArchive): signal_variance and noise_variance in [1e-100, 1e100],
// `kernel_inputs` (KernelInputs) lengthscales in [1e-50, 1e50] (wide enough for
// every fit the server makes, value_ranges.h). INVALID_ARGUMENT naming
// the field under `path`, e.g. "config.kernel.fixed[1].lengthscales[2]".
absl::Status ValidateHyperparameters(absl::string_view path,
                                     const v1::Hyperparameters& hyperparameters,
                                     int kernel_inputs);

// Lengthscales of each output's kernel: state_dim + input_dim + one per angle
// (its sine and cosine).
int KernelInputs(const v1::SessionConfig& config);

// Convenience: a validated copy with defaults filled.
absl::StatusOr<v1::SessionConfig> ValidatedSessionConfig(
    const v1::SessionConfig& config, absl::string_view path = "config");

}  // namespace excite::service

#endif  // EXCITE_SERVER_SERVICE_CONFIG_VALIDATION_H_
