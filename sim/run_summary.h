#ifndef EXCITE_SIM_RUN_SUMMARY_H_
#define EXCITE_SIM_RUN_SUMMARY_H_

#include <cstdint>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"

namespace excite::sim {

// The RMSE of the session's model after `samples` transitions.
struct RmsePoint {
  int64_t samples = 0;
  double rmse = 0.0;
};

// A real-time run (ExplorationOptions::realtime_hz): where each tick's input came
// from.
struct RealtimeStats {
  double hz = 0.0;              // 0: a lock-step run (the rest unset)
  int64_t ticks_from_plan = 0;  // the input was a plan's row for that tick
  int64_t ticks_fell_back = 0;  // no plan row: the last input held
  int64_t late_plans = 0;       // plans that arrived after their first step
  int64_t overruns = 0;         // ticks that began more than a period late
};

// What one exploration run produced (see exploration_run.h for how each field is
// measured and evaluation.h for the metrics' definitions).
struct RunSummary {
  std::string system;
  std::string strategy;  // StrategyName: "rec", "pa", "mi", ...
  std::string session;   // "sessions/{id}".
  int64_t samples = 0;   // Transitions collected and stored.
  double final_rmse = 0.0;
  // The final RMSE per state dimension (RmsePerDimension); empty if never evaluated.
  std::vector<double> final_rmse_per_dimension;
  // The session's state_names and state_units (empty if the config names none).
  std::vector<std::string> state_names;
  std::vector<std::string> state_units;
  // Calibration of the last evaluation (evaluation.h, ComputeCalibration): mean
  // negative log predictive density [nats] and the share of errors inside the 95 %
  // interval; NaN if never evaluated.
  double final_nlpd = std::numeric_limits<double>::quiet_NaN();
  double final_inside_95 = std::numeric_limits<double>::quiet_NaN();
  // Multi-step prediction at the end: RMSE of the model's mean rolled out open loop
  // from the true start under the true inputs, after 10 and 30 steps, over the
  // trajectories of a RolloutSet (exploration_run.h); NaN if not computed.
  double rollout_rmse_10 = std::numeric_limits<double>::quiet_NaN();
  double rollout_rmse_30 = std::numeric_limits<double>::quiet_NaN();
  // The same at the first evaluation with at least half of the samples (0 and NaN
  // if there was none).
  int64_t midway_samples = 0;
  double midway_rmse = std::numeric_limits<double>::quiet_NaN();
  double midway_rollout_rmse_10 = std::numeric_limits<double>::quiet_NaN();
  double midway_rollout_rmse_30 = std::numeric_limits<double>::quiet_NaN();
  double coverage_marginal = 0.0;        // Fraction in [0, 1].
  std::optional<double> coverage_joint;  // Not computed for state_dim > 4.
  std::vector<RmsePoint> rmse_history;   // In order of samples.
  double plan_ms_p50 = 0.0;              // Median PlanInputs round trip [ms].
  int64_t plans = 0;                     // Successful PlanInputs calls.
  // Successful PlanInputs calls per strategy that made the plan (its short name;
  // for auto, the members its bandit drew).
  std::map<std::string, int64_t> planned_by;
  int64_t random_steps = 0;  // Random inputs applied before min_samples.
  int64_t plan_retries = 0;  // PlanInputs retried after DEADLINE_EXCEEDED.
  // With a safe box (session.safety.state_bounds): the fraction of visited (true)
  // states outside it, in [0, 1]; not set without a box.
  std::optional<double> left_safe_box;
  double wall_s = 0.0;       // Wall time of the whole run [s].
  double plan_ms_p90 = 0.0;  // Percentiles of the same round trips [ms].
  double plan_ms_p99 = 0.0;
  RealtimeStats realtime;
};

// The summary as one JSON object with the keys system, strategy, session, samples,
// final_rmse, final_rmse_per_dimension ([...]), state_names, state_units ([...]),
// final_nlpd, final_inside_95, rollout_rmse_10, rollout_rmse_30, midway_samples,
// midway_rmse, midway_rollout_rmse_10, midway_rollout_rmse_30, coverage_marginal,
// coverage_joint, rmse_history ([[samples, rmse], ...]), plan_ms_p50, plans, planned_by
// ({"rec": n, ...}), random_steps, plan_retries,
// left_safe_box, wall_s, plan_ms_p90, plan_ms_p99 and, for a real-time run,
// realtime ({"hz", "ticks_from_plan", "ticks_fell_back", "late_plans",
// "overruns"}; null for lock-step). Non-finite numbers and a missing coverage_joint or
// left_safe_box are written as null. Ends with a newline.
std::string RunSummaryToJson(const RunSummary& summary);

// Writes RunSummaryToJson(summary) to `path` (replacing it). INTERNAL naming the
// path if it cannot be written.
absl::Status WriteRunSummary(const RunSummary& summary, const std::string& path);

// The median of `values` (mean of the two middle ones for an even count; 0 if
// empty). Takes a copy: O(n) expected time.
double Median(std::vector<double> values);

// The q-quantile (q in [0, 1]) of `values` by linear interpolation between order
// statistics (0 if empty).
double Quantile(std::vector<double> values, double q);

}  // namespace excite::sim

#endif  // EXCITE_SIM_RUN_SUMMARY_H_
