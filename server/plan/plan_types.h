#ifndef EXCITE_SERVER_PLAN_PLAN_TYPES_H_
#define EXCITE_SERVER_PLAN_PLAN_TYPES_H_

#include <Eigen/Dense>
#include <chrono>
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "absl/status/status.h"
#include "server/plan/safe_box.h"
#include "server/plan/strategy.h"

namespace excite::plan {

// Parameters of the open-loop signals. Time is in samples (the server does not
// know the plant's sampling time), frequencies in cycles per sample.
struct SignalOptions {
  int prbs_min_hold = 5;                // samples per PRBS clock period (>= 1)
  double chirp_start_frequency = 0.01;  // cycles/sample at the start of a sweep
  double chirp_end_frequency = 0.2;     // cycles/sample at the end of a sweep
  int chirp_period = 200;               // samples per sweep (the sweep repeats)
  int random_hold = 1;                  // samples each random input is held (>= 1)
};

// Parameters of sep's search for z* = argmax H(z) over the box state x input
// bounds (L-BFGS-B, multi-start). The steering uses PlanOptions' horizon (at most
// M steering steps), max_iterations, restarts and tolerance.
struct SepOptions {
  int search_starts = 4;       // L-BFGS-B starts (the first: best random sample)
  int search_samples = 256;    // uniform random samples the first start is picked from
  int search_iterations = 50;  // L-BFGS-B iterations per start
};

// Options of one session's planner. Defaults documented here are the API's.
struct PlanOptions {
  Strategy strategy = Strategy::kRec;
  int horizon = 15;  // M; a strategy's fixed_horizon (greedy: 1) overrides it
  Eigen::VectorXd input_lower;
  Eigen::VectorXd input_upper;
  // Region of interest of the state (empty or state_dim entries each); required
  // by kSep (its search box and the scale of its steering distance) and kRoi
  // (with the input bounds, the box of its reference set).
  Eigen::VectorXd state_lower;
  Eigen::VectorXd state_upper;
  // State dimensions that are angles (as the model's angle_dims): sep steers to
  // the turn of its target nearest the current state.
  std::vector<int> angle_dims;
  int max_iterations = 100;  // Ipopt iterations per start
  int restarts = 1;          // random starts on top of the warm start
  double tolerance = 1e-4;   // Ipopt tol
  uint64_t seed = 0;
  SignalOptions signal;
  SepOptions sep;
  // kRoi: points of the reference set over state x input bounds (>= 1).
  int roi_reference_points = 256;
  // kOptimistic: the hallucinated deviation from the mean, in one-step latent
  // standard deviations (> 0): x_{i+1} = mean + beta sd o eta, eta in [-1, 1]^dx.
  // 1 lets the plan assume any next state within one standard deviation of the
  // mean (OPAX scales beta with a confidence level; 1 is its order for
  // well-calibrated GPs).
  double optimism_beta = 1.0;
  // kAuto: the member strategies it chooses among (each CanBeAutoMember, no
  // repeats); empty: DefaultAutoMembers.
  std::vector<Strategy> auto_members;
  AutoChooser auto_chooser = AutoChooser::kPortfolio;
  // auto_members, or DefaultAutoMembers for these options' state bounds and chooser.
  std::vector<Strategy> AutoMembers() const;
  // State constraints on the planned mean trajectory of every model-based
  // strategy (inactive by default).
  SafeBox safe_box;

  // INVALID_ARGUMENT unless the options suit a model of these dimensions: input
  // bounds (input_dim finite, lower <= upper), horizon >= 1 (unless the
  // strategy fixes it), iterations and restarts >= 0, tolerance > 0, the safe
  // box, the signal's parameters and the state bounds a strategy needs. The
  // Planner calls it once per model shape (Ceres-style: options in, checked once).
  absl::Status Validate(int state_dim, int input_dim) const;
};

// Limits of one call: the best plan so far is returned when one is hit.
struct PlanLimits {
  std::optional<std::chrono::steady_clock::time_point> deadline;
  // Polled between Ipopt iterations; true stops the solve (CANCELLED).
  std::function<bool()> cancelled;
};

// What the caller knows of the plan's start beyond x0 and its time index.
struct PlanStart {
  // x0 was measured. False when it is the model's prediction after inputs the
  // plant has committed to: auto then scores no member on it.
  bool measured = true;
  // Steps from the previous plan's first input to this plan's first input, when
  // the caller knows them (the plant ran ahead of the plans): the warm start is
  // the previous plan shifted by as many. Unknown: by its apply_count, the steps
  // a lock-step plant applies.
  std::optional<int64_t> steps_since_previous;
};

enum class PlanStatus { kConverged, kTimeLimit, kIterationLimit, kNotConverged };

struct Plan {
  Eigen::MatrixXd inputs;  // H x input_dim: u_k .. u_{k+H-1}
  // H x state_dim: x_k .. x_{k+H-1} under the GP mean; 0 rows for the model-free
  // strategies (they never evaluate the model).
  Eigen::MatrixXd states;
  // H x state_dim: latent variance at (x_{k+i}, u_{k+i}); 0 rows when states has.
  Eigen::MatrixXd variances;
  int apply_count = 1;  // inputs to apply before planning again
};

struct PlanSummary {
  PlanStatus status = PlanStatus::kNotConverged;
  int iterations = 0;  // Ipopt iterations summed over starts (+ L-BFGS-B for sep)
  int starts = 0;      // Ipopt starts solved
  // What the strategy maximised, on the returned plan: the summed differential
  // entropy (nats) for rec, pa, greedy and sep; the mutual information (nats) for
  // mi; the fraction of the summed variance over the reference set removed for
  // roi; sum log(1 + var / noise) along the optimistic trajectory (nats) for
  // optimistic; 0 for the model-free strategies.
  double objective = 0.0;
  double wall_time_ms = 0.0;
  // With a safe box: how far the returned plan's predictions violate it (state
  // units, margin included); 0 if it keeps the box (no feasible plan was found
  // otherwise: the plan is the least violating one).
  double safe_box_violation = 0.0;
  // The strategy that made the plan: auto's drawn member, else the strategy.
  Strategy planned_by = Strategy::kRec;
  // kSep only: the searched z* = (x*, u*) and its entropy H(z*) (nats).
  Eigen::VectorXd search_point;
  double search_entropy = 0.0;
};

}  // namespace excite::plan

#endif  // EXCITE_SERVER_PLAN_PLAN_TYPES_H_
