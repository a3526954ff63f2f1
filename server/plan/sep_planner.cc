#include "server/plan/sep_planner.h"

#include <random>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "common/angles.h"
#include "server/plan/entropy_objective.h"
#include "server/plan/entropy_search.h"
#include "server/plan/rollout.h"
#include "server/plan/shooting_solver.h"
#include "server/plan/steering_objective.h"

namespace excite::plan {
namespace {

// Uniform in [0, 1) from 53 random bits: the same on every platform.
double Uniform01(std::mt19937_64& rng) {
  return static_cast<double>(rng() >> 11) * 0x1.0p-53;
}

}  // namespace

absl::StatusOr<Plan> PlanSeparated(const gp::DynamicsPredictor& model,
                                   const Eigen::VectorXd& x0, const PlanOptions& options,
                                   uint64_t seed, const std::function<bool()>& stop,
                                   PlanSummary* summary) {
  const int dx = model.state_dim();
  const int du = model.input_dim();
  const Eigen::VectorXd& state_lower = options.state_lower;
  const Eigen::VectorXd& state_upper = options.state_upper;
  const Eigen::VectorXd& input_lower = options.input_lower;
  const Eigen::VectorXd& input_upper = options.input_upper;

  // 1. Search.
  Eigen::VectorXd box_lower(dx + du);
  Eigen::VectorXd box_upper(dx + du);
  box_lower << state_lower, input_lower;
  box_upper << state_upper, input_upper;
  // With a safe box, search only where the plant may go: region x safe box.
  const SafeBox& safe = options.safe_box;
  if (safe.active()) {
    const Eigen::VectorXd lo = state_lower.cwiseMax(safe.lower);
    const Eigen::VectorXd hi = state_upper.cwiseMin(safe.upper);
    const bool overlap = (lo.array() < hi.array()).all();
    box_lower.head(dx) = overlap ? lo : safe.lower;
    box_upper.head(dx) = overlap ? hi : safe.upper;
  }
  EntropySearchOptions search_options;
  search_options.starts = options.sep.search_starts;
  search_options.samples = options.sep.search_samples;
  search_options.iterations = options.sep.search_iterations;
  search_options.seed = seed;
  const EntropySearchResult search =
      SearchMaxEntropy(model, box_lower, box_upper, search_options, stop);
  if (search.z.size() != dx + du) {
    return absl::InternalError(
        "sep: the model's variance is not finite anywhere in the search box");
  }
  Eigen::VectorXd target = search.z.head(dx);
  // An angle's target is any of its turns: the nearest one is the shortest way.
  for (int a : options.angle_dims) target(a) = x0(a) + WrapAngle(target(a) - x0(a));
  const Eigen::VectorXd target_input = search.z.tail(du);

  // 2. Control: steer towards x*.
  const Eigen::VectorXd half_width = 0.5 * (state_upper - state_lower);
  const SteeringObjective steering(target,
                                   half_width.array().square().inverse().matrix());
  const int horizon = options.horizon;
  std::vector<Eigen::MatrixXd> starts;
  starts.push_back((0.5 * (input_lower + input_upper)).transpose().replicate(horizon, 1));
  std::mt19937_64 rng(seed ^ 0x5e9a5e9a5e9a5e9aULL);
  for (int r = 0; r < options.restarts; ++r) {
    Eigen::MatrixXd random(horizon, du);
    for (int i = 0; i < horizon; ++i) {
      for (int l = 0; l < du; ++l) {
        random(i, l) =
            input_lower(l) + (input_upper(l) - input_lower(l)) * Uniform01(rng);
      }
    }
    starts.push_back(std::move(random));
  }
  ShootingSettings settings;
  settings.max_iterations = options.max_iterations;
  settings.tolerance = options.tolerance;
  settings.safe_box = safe;
  const ShootingResult steered = SolveFromStarts(
      model, steering, x0, input_lower, input_upper, std::move(starts), settings, stop);
  if (!steered.best.valid) {
    return absl::InternalError(
        "sep: the model's predictions are not finite along any steering start");
  }

  // 3. Cut at the predicted state closest to x*, then apply u*.
  int closest = 0;
  double closest_distance = steering.Distance(x0);
  for (int i = 1; i <= horizon; ++i) {
    const double d = steering.Distance(steered.best.means.row(i - 1).transpose());
    if (d < closest_distance) {
      closest_distance = d;
      closest = i;
    }
  }
  Eigen::MatrixXd inputs(closest + 1, du);
  inputs.topRows(closest) = steered.best.inputs.topRows(closest);
  inputs.row(closest) = target_input.transpose();
  Rollout final_plan = RollOut(model, x0, inputs);
  if (!final_plan.valid) {
    return absl::InternalError(
        "sep: the model's predictions are not finite along the plan");
  }
  // u* was searched in the box, not planned under the safe box: if it would leave
  // the box, apply the steering plan's own next input instead (a prefix of a plan
  // that keeps the box keeps it).
  if (safe.active() && SafeBoxViolation(safe, final_plan.means, final_plan.variances) >
                           steered.safe_box_violation) {
    if (closest < steered.best.inputs.rows()) {
      inputs.row(closest) = steered.best.inputs.row(closest);
    } else {
      inputs = steered.best.inputs;  // the whole steering plan, without u*
    }
    final_plan = RollOut(model, x0, inputs);
    if (!final_plan.valid) {
      return absl::InternalError(
          "sep: the model's predictions are not finite along the plan");
    }
  }

  Plan plan;
  plan.inputs = std::move(final_plan.inputs);
  plan.states = std::move(final_plan.states);
  plan.variances = std::move(final_plan.variances);
  plan.apply_count = static_cast<int>(plan.inputs.rows());
  if (summary != nullptr) {
    summary->status = search.stopped ? PlanStatus::kTimeLimit : steered.status;
    summary->iterations = search.iterations + steered.iterations;
    summary->starts = steered.starts;
    summary->objective = Entropy(plan.variances);
    summary->search_point = search.z;
    summary->search_entropy = search.entropy;
    summary->safe_box_violation =
        SafeBoxViolation(safe, final_plan.means, plan.variances);
  }
  return plan;
}

}  // namespace excite::plan
