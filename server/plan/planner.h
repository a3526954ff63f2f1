#ifndef EXCITE_SERVER_PLAN_PLANNER_H_
#define EXCITE_SERVER_PLAN_PLANNER_H_

#include <Eigen/Dense>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <utility>

#include "absl/status/statusor.h"
#include "server/gp/dynamics_predictor.h"
#include "server/plan/plan_types.h"
#include "server/plan/shooting_objective.h"

namespace excite::plan {

class AutoPlanner;

// One session's planner: options in (PlanOptions, plan_types.h), a plan and a
// summary out. Dispatches on options.strategy:
//  - kRec, kPa, kGreedy: the paper's problem (trajopt_optim) by direct multiple
//    shooting with Ipopt: maximise sum_i H(x_i, u_i) s.t. x_{i+1} = mean(x_i, u_i),
//    u_i in bounds. Keeps the previous plan to warm-start the next call (shifted by
//    its apply_count, or by PlanStart::steps_since_previous). apply_count: 1 (rec,
//    greedy, mi, roi) or M (pa).
//  - kOptimistic: the same NLP and receding horizon on optimistic dynamics
//    x_{i+1} = mean + optimism_beta sd o eta_i with hallucinated controls eta_i
//    in [-1, 1]^dx as extra variables, maximising sum log(1 + var / noise)
//    (optimistic_objective.h); the plan's states are the optimistic trajectory.
//    Needs the model's observation noise variances (INVALID_ARGUMENT if not).
//  - kMi, kRoi: the same NLP and receding horizon with an information objective
//    over the horizon's points jointly (information_objectives.h): mutual
//    information, or the variance removed over a Halton reference set of
//    roi_reference_points points in state x input bounds (roi needs state
//    bounds). Both need a model with joint covariances (INVALID_ARGUMENT if not).
//  - kPrbs, kChirp, kRandom: the open-loop signals (prbs_signal.h,
//    chirp_signal.h, random_signal.h) at samples time_index .. time_index + M - 1;
//    the model is never evaluated (it need not be fitted), states/variances have 0
//    rows, apply_count = M, the summary reports kConverged and objective 0.
//  - kSep: separated search and control (sep_planner.h); needs state bounds.
//  - kAuto: a choice among member strategies (auto_planner.h: a bandit, or a
//    portfolio judged by one model criterion), each planning with its own
//    Planner; apply_count = 1.
// Ipopt solves are serialised process-wide (MUMPS in Ipopt 3.11 is not
// thread-safe). Not thread-safe itself: one session's calls are serialised.
class Planner {
 public:
  explicit Planner(PlanOptions options);
  Planner(Planner&&) noexcept;
  Planner& operator=(Planner&&) noexcept;
  ~Planner();

  // x0: the current state; time_index: its sample index k (>= 0), the position of
  // the first returned input in the model-free signals (the session passes the
  // number of samples it holds, so a restarted session continues the signal).
  // INVALID_ARGUMENT if x0 has the wrong size or is not finite, if the options are
  // invalid (input bounds, horizon, iterations, signal parameters, sep's state
  // bounds) or time_index < 0; CANCELLED if limits.cancelled fired before any
  // feasible plan existed. `start`: see PlanStart.
  absl::StatusOr<Plan> PlanInputs(const gp::DynamicsPredictor& model,
                                  const Eigen::VectorXd& x0, int64_t time_index,
                                  const PlanLimits& limits, PlanSummary* summary,
                                  const PlanStart& start = {});

  const PlanOptions& options() const { return options_; }

 private:
  // The kTrajectory strategies: one multiple-shooting NLP, the strategy's
  // objective.
  absl::StatusOr<Plan> PlanTrajectory(const StrategyInfo& strategy,
                                      const gp::DynamicsPredictor& model,
                                      const Eigen::VectorXd& x0, uint64_t call,
                                      const std::function<bool()>& stop,
                                      const PlanStart& start, PlanSummary* summary);
  // The kSignal strategies.
  Plan PlanSignal(const StrategyInfo& strategy, int state_dim, int64_t time_index) const;

  PlanOptions options_;
  // options_.Validate() for the model shape (state_dim, input_dim) it was last
  // checked for.
  std::optional<std::pair<int, int>> validated_for_;
  absl::Status options_status_;
  std::optional<Plan> previous_;
  // roi's reference set (a function of the options only; made at the first plan).
  Eigen::MatrixXd reference_;
  uint64_t calls_ = 0;
  // kAuto: its members' planners and bandit (made at the first plan).
  std::unique_ptr<AutoPlanner> auto_;
};

}  // namespace excite::plan

#endif  // EXCITE_SERVER_PLAN_PLANNER_H_
