#ifndef EXCITE_SERVER_SERVICE_VALUE_RANGES_H_
#define EXCITE_SERVER_SERVICE_VALUE_RANGES_H_

// The ranges of the numbers a request may carry. They are chosen so that
// everything the model computes from accepted numbers stays finite: the GP
// squares differences of inputs divided by lengthscales (or by interval
// half-widths, then by fitted lengthscales of at least 1e-6) and sums squared
// targets over up to 20,000 samples. With data within +-1e30, interval widths
// of at least 1e-30 and fixed lengthscales of at least 1e-50, the largest such
// square is about (2e30 / 1e-50)^2 * 72 dimensions ~ 3e162, far below the
// double range (1.8e308). A plant in any physical units stays well inside them;
// a number outside is a bug or an attack, and would otherwise leave a session
// whose model can no longer answer. The hyperparameter ranges are wide enough
// to hold every fit the server itself can produce, so an exported session
// imports again.

#include <cstdint>

namespace excite::service {

// States, inputs, next states, Predict inputs, PlanInputs states and the bounds
// of every state and input interval: |value| <= kMaxAbsValue.
inline constexpr double kMaxAbsValue = 1e30;
// Widths of state and input intervals (they normalise the model's inputs).
inline constexpr double kMinIntervalWidth = 1e-30;
// noise.variance (state units squared).
inline constexpr double kMinNoiseVariance = 1e-30;
inline constexpr double kMaxNoiseVariance = 1e30;
// Hyperparameters in data units (kernel.fixed, archived fits): lengthscales
// and variances.
inline constexpr double kMinLengthscale = 1e-50;
inline constexpr double kMaxLengthscale = 1e50;
inline constexpr double kMinHyperVariance = 1e-100;
inline constexpr double kMaxHyperVariance = 1e100;
// kernel.lengthscale_bounds and kernel.signal_variance_bounds, on standardised
// data (defaults [0.05, 50] and [0.01, 100]) must lie within these.
inline constexpr double kMinFitLengthscale = 1e-6;
inline constexpr double kMaxFitLengthscale = 1e6;
inline constexpr double kMinFitSignalVariance = 1e-12;
inline constexpr double kMaxFitSignalVariance = 1e12;
// planner.time_budget_s: a millisecond is the least in which a solve can return
// anything; an hour the most a client should wait for one call.
inline constexpr double kMinTimeBudgetS = 1e-3;
inline constexpr double kMaxTimeBudgetS = 3600.0;
// Transition.sequence: at most 2^53, the largest integer a JSON number (the
// live view, a JavaScript client) holds exactly, so that a client can always
// number the next sample last_sequence + 1. At 1 kHz a plant reaches it in
// 285,000 years.
inline constexpr int64_t kMaxSequence = int64_t{1} << 53;
// Times in milliseconds since the Unix epoch (SessionArchive.created_unix_ms):
// at most the last millisecond of 9999-12-31 UTC, google.protobuf.Timestamp's
// largest, so that every stored time converts back to the wire.
inline constexpr int64_t kMaxUnixMs = 253402300799999;

}  // namespace excite::service

#endif  // EXCITE_SERVER_SERVICE_VALUE_RANGES_H_
