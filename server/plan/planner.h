#ifndef EXCITE_SERVER_PLAN_PLANNER_H_
#define EXCITE_SERVER_PLAN_PLANNER_H_

#include <chrono>
#include <cstdint>
#include <functional>
#include <optional>

#include <Eigen/Dense>

#include "absl/status/statusor.h"
#include "server/gp/dynamics_predictor.h"

namespace excite::plan {

enum class Strategy {
  kRec,     // plan M, apply the first input, replan
  kPa,      // plan M, apply all M, replan
  kGreedy,  // rec with M = 1
};

// Options of one session's planner. Defaults documented here are the API's.
struct PlanOptions {
  Strategy strategy = Strategy::kRec;
  int horizon = 15;  // M; forced to 1 for kGreedy
  Eigen::VectorXd input_lower;
  Eigen::VectorXd input_upper;
  int max_iterations = 100;  // Ipopt iterations per start
  int restarts = 1;          // random starts on top of the warm start
  double tolerance = 1e-4;   // Ipopt tol
  uint64_t seed = 0;
};

// Limits of one call: the best plan so far is returned when one is hit.
struct PlanLimits {
  std::optional<std::chrono::steady_clock::time_point> deadline;
  // Polled between Ipopt iterations; true stops the solve (CANCELLED).
  std::function<bool()> cancelled;
};

enum class PlanStatus { kConverged, kTimeLimit, kIterationLimit, kNotConverged };

struct Plan {
  Eigen::MatrixXd inputs;     // M x input_dim: u_k .. u_{k+M-1}
  Eigen::MatrixXd states;     // M x state_dim: x_k .. x_{k+M-1} under the GP mean
  Eigen::MatrixXd variances;  // M x state_dim: latent variance at (x_{k+i}, u_{k+i})
  int apply_count = 1;        // inputs to apply before planning again
};

struct PlanSummary {
  PlanStatus status = PlanStatus::kNotConverged;
  int iterations = 0;      // summed over starts
  int starts = 0;
  double objective = 0.0;  // summed differential entropy of the returned plan (nats)
  double wall_time_ms = 0.0;
};

// Solves the paper's problem (trajopt_optim) by direct multiple shooting with
// Ipopt: maximise sum_i H(x_i, u_i) s.t. x_{i+1} = mean(x_i, u_i), u_i in bounds.
// Keeps the previous plan to warm-start the next call (shifted by its
// apply_count). Ipopt solves are serialised process-wide (MUMPS in Ipopt 3.11 is
// not thread-safe). Not thread-safe itself: one session's calls are serialised.
class Planner {
 public:
  explicit Planner(PlanOptions options);

  // INVALID_ARGUMENT if x0 has the wrong size or is not finite, CANCELLED if
  // limits.cancelled fired before any feasible plan existed.
  absl::StatusOr<Plan> PlanInputs(const gp::DynamicsPredictor& model,
                                  const Eigen::VectorXd& x0, const PlanLimits& limits,
                                  PlanSummary* summary);

  const PlanOptions& options() const { return options_; }

 private:
  PlanOptions options_;
  std::optional<Plan> previous_;
  uint64_t calls_ = 0;
};

}  // namespace excite::plan

#endif  // EXCITE_SERVER_PLAN_PLANNER_H_
