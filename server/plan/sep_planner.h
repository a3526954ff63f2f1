#ifndef EXCITE_SERVER_PLAN_SEP_PLANNER_H_
#define EXCITE_SERVER_PLAN_SEP_PLANNER_H_

#include <Eigen/Dense>
#include <cstdint>
#include <functional>

#include "absl/status/statusor.h"
#include "server/gp/dynamics_predictor.h"
#include "server/plan/plan_types.h"

namespace excite::plan {

// Separated search and control (sep, paper Section 4.2), one call:
//  1. Search: z* = (x*, u*) = argmax H(z) over the box state bounds x input bounds
//     (SearchMaxEntropy: multi-start L-BFGS-B with the analytic gradient; starts:
//     the best of options.sep.search_samples random points, then
//     options.sep.search_starts - 1 random points; seeded by `seed`).
//  2. Control: steer towards x* on the model mean by direct multiple shooting with
//     Ipopt (SolveFromStarts with SteeringObjective over M = options.horizon steps,
//     J = sum_{i=1}^{M} ||x_i - x*||_W^2, W = diag(1 / half-width^2) of the state
//     bounds; input bounds; starts: the mid-bound constant sequence and
//     options.restarts uniformly random sequences).
//  3. The best steering rollout is cut after the step i* in 0..M whose predicted
//     state x_{i*} is closest to x* (the first such step; i* = 0 if no predicted
//     state is closer than x_0), and u* is appended: the plan is
//     (u_0 .. u_{i*-1}, u*), i* + 1 <= M + 1 inputs, all to be applied
//     (apply_count = i* + 1). states/variances are those of this plan rolled out
//     through the mean (x_0 .. x_{i*}).
// The summary's objective is the summed entropy of the returned plan, iterations
// add the L-BFGS-B and Ipopt iterations, starts counts the Ipopt starts,
// search_point/search_entropy give z* and H(z*). options.state_lower/upper
// must have state_dim finite entries with lower < upper (the Planner checks it
// for every strategy whose row needs state bounds). `stop` is polled throughout; once it
// fires, the best so far is used (status kTimeLimit).
absl::StatusOr<Plan> PlanSeparated(const gp::DynamicsPredictor& model,
                                   const Eigen::VectorXd& x0, const PlanOptions& options,
                                   uint64_t seed, const std::function<bool()>& stop,
                                   PlanSummary* summary);

}  // namespace excite::plan

#endif  // EXCITE_SERVER_PLAN_SEP_PLANNER_H_
