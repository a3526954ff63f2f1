#ifndef EXCITE_SERVER_PLAN_SHOOTING_SOLVER_H_
#define EXCITE_SERVER_PLAN_SHOOTING_SOLVER_H_

#include <Eigen/Dense>
#include <functional>
#include <limits>
#include <vector>

#include "server/gp/dynamics_predictor.h"
#include "server/plan/plan_types.h"
#include "server/plan/rollout.h"
#include "server/plan/safe_box.h"
#include "server/plan/shooting_objective.h"

namespace excite::plan {

struct ShootingSettings {
  int max_iterations = 100;  // Ipopt iterations per start
  double tolerance = 1e-4;   // Ipopt tol
  // Stall rule: from a start's 10th Ipopt iteration on, every 5th, its newest point
  // is rolled out (a candidate plan like the others); the start ends, as converged,
  // once its best rollout has not improved by more than stall_tolerance x
  // max(1, |best|) for max_iterations / 10 iterations. 0 turns it off.
  double stall_tolerance = 0.0;
  double objective_scaling = 1.0;  // Ipopt obj_scaling_factor
  SafeBox safe_box;                // state constraints (inactive by default)
  // > 0: optimistic dynamics (MultipleShootingNlp::SetOptimism); the plans are
  // then rolled out through them and `best.states` is the hallucinated trajectory.
  double optimism_beta = 0.0;
};

struct ShootingResult {
  Rollout best;  // best.valid is false if no start had a finite rollout
  double value = std::numeric_limits<double>::infinity();  // objective of `best`
  // SafeBoxViolation of `best` (0 when it keeps the box or no box is set).
  double safe_box_violation = 0.0;
  int best_start = -1;
  // kTimeLimit if `stop` ended the starts, otherwise how the Ipopt solve of the
  // best rollout's start ended (kNotConverged if it came from an unsolved start).
  PlanStatus status = PlanStatus::kNotConverged;
  int iterations = 0;  // Ipopt iterations, summed over the solved starts
  int starts = 0;      // starts solved with Ipopt
  bool stopped = false;
};

// Multi-start direct multiple shooting on the model mean, shared by every
// model-based strategy. Each start (an M x du input sequence, clipped into the
// bounds) is rolled out; every rollout is a feasible plan. Then, in order, each
// start with a finite rollout is solved by Ipopt (MultipleShootingNlp with
// `objective`, through SolveTnlp, i.e. under the process-wide Ipopt mutex, with
// analytic first derivatives and a limited-memory Hessian), and the NLP's best
// feasible and final points are rolled out again (inputs clipped into the bounds),
// as are the points the stall rule checks (ShootingSettings::stall_tolerance).
// With optimism, each start begins with eta = 0 (the mean) and the NLP's points
// are rolled out with their hallucinated controls. Returns the rollout with the
// lowest objective (evaluated on the rollout, where the dynamics hold exactly); with an
// active safe box, a rollout that keeps it (violation <= kSafeBoxTolerance) beats any
// that does not, and among those that do not the smallest violation wins. `stop` is
// polled before each start and at every Ipopt iteration; once it fires no further start
// is solved.
ShootingResult SolveFromStarts(const gp::DynamicsPredictor& model,
                               const ShootingObjective& objective,
                               const Eigen::VectorXd& x0, const Eigen::VectorXd& lower,
                               const Eigen::VectorXd& upper,
                               std::vector<Eigen::MatrixXd> starts,
                               const ShootingSettings& settings,
                               const std::function<bool()>& stop);

// The objective of a rollout (no derivatives).
double RolloutObjective(const ShootingObjective& objective, const Rollout& rollout);

}  // namespace excite::plan

#endif  // EXCITE_SERVER_PLAN_SHOOTING_SOLVER_H_
