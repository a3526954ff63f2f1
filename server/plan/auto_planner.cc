#include "server/plan/auto_planner.h"

#include <cmath>
#include <utility>

#include "common/angles.h"
#include "server/plan/counter_random.h"
#include "server/plan/member_portfolio.h"
#include "server/plan/rollout.h"

namespace excite::plan {
namespace {

constexpr uint64_t kAutoStream = 0x6175746f;  // "auto"

// A signal member's plan with its inputs rolled out through the mean, as the
// other members' plans report them.
absl::Status WithMeanTrajectory(const gp::DynamicsPredictor& model,
                                const Eigen::VectorXd& x0, Plan* plan) {
  if (plan->states.rows() != 0) return absl::OkStatus();
  Rollout rollout = RollOut(model, x0, plan->inputs);
  if (!rollout.valid) {
    return absl::InternalError(
        "the model's predictions are not finite along the signal's inputs");
  }
  plan->states = std::move(rollout.states);
  plan->variances = std::move(rollout.variances);
  return absl::OkStatus();
}

}  // namespace

AutoPlanner::AutoPlanner(const PlanOptions& options)
    : options_(options),
      seed_(options.seed),
      angle_dims_(options.angle_dims),
      members_(options.AutoMembers()),
      bandit_(static_cast<int>(members_.size()), kAutoGamma) {
  planners_.reserve(members_.size());
  for (Strategy member : members_) {
    PlanOptions own = options;
    own.strategy = member;
    own.auto_members.clear();
    planners_.emplace_back(std::move(own));
  }
}

void AutoPlanner::ScorePending(const Eigen::VectorXd& x0, int64_t time_index) {
  if (!pending_.has_value()) return;
  const Pending pending = *std::move(pending_);
  pending_.reset();
  // Not one sample later: the client applied more or fewer inputs than the first,
  // so x0 is not the answer to it.
  if (time_index != pending.time_index + 1 || pending.predicted.size() != x0.size()) {
    return;
  }
  Eigen::VectorXd error = x0 - pending.predicted;
  for (int a : angle_dims_) error(a) = WrapAngle(error(a));
  if (!error.allFinite()) return;
  bandit_.Reward(pending.member, pending.probability, surprise_.Reward(error));
}

absl::StatusOr<Plan> AutoPlanner::PlanInputs(const gp::DynamicsPredictor& model,
                                             const Eigen::VectorXd& x0,
                                             int64_t time_index, const PlanLimits& limits,
                                             bool x0_measured, PlanSummary* summary) {
  PlanSummary local;
  absl::StatusOr<Plan> plan =
      options_.auto_chooser == AutoChooser::kPortfolio
          ? PlanByPortfolio(model, x0, time_index, limits, &local)
          : PlanByBandit(model, x0, time_index, limits, x0_measured, &local);
  if (!plan.ok()) return plan.status();
  plan->apply_count = 1;
  if (summary != nullptr) *summary = local;
  return plan;
}

absl::StatusOr<Plan> AutoPlanner::PlanByBandit(const gp::DynamicsPredictor& model,
                                               const Eigen::VectorXd& x0,
                                               int64_t time_index,
                                               const PlanLimits& limits, bool x0_measured,
                                               PlanSummary* summary) {
  if (x0_measured) {
    ScorePending(x0, time_index);
  } else {
    pending_.reset();
  }
  const uint64_t call = calls_++;
  const Eigen::VectorXd probabilities = bandit_.Probabilities();
  const int member = bandit_.Draw(CounterUniform(seed_, kAutoStream, 0, call));
  absl::StatusOr<Plan> plan = planners_[static_cast<size_t>(member)].PlanInputs(
      model, x0, time_index, limits, summary);
  if (!plan.ok()) return plan.status();
  if (absl::Status s = WithMeanTrajectory(model, x0, &*plan); !s.ok()) return s;
  if (x0_measured) {
    // The first transition's predicted mean, with the model as it is now.
    Eigen::MatrixXd z0(1, model.z_dim());
    z0 << x0.transpose(), plan->inputs.row(0);
    Eigen::MatrixXd mean;
    model.Predict(z0, &mean, nullptr, nullptr, nullptr);
    pending_ =
        Pending{member, probabilities(member), time_index, mean.row(0).transpose()};
  }
  summary->planned_by = members_[static_cast<size_t>(member)];
  return plan;
}

absl::StatusOr<Plan> AutoPlanner::PlanByPortfolio(const gp::DynamicsPredictor& model,
                                                  const Eigen::VectorXd& x0,
                                                  int64_t time_index,
                                                  const PlanLimits& limits,
                                                  PlanSummary* summary) {
  absl::StatusOr<PortfolioCriterion> criterion =
      PortfolioCriterion::Create(model, options_, &reference_);
  if (!criterion.ok()) return criterion.status();
  std::vector<MemberPlan> plans =
      PlanEveryMember(planners_, model, x0, time_index, limits);
  int best = -1;
  double best_score = 0.0;
  Rollout best_rollout;  // the chosen plan's mean trajectory, scored once
  absl::Status first_error;
  for (size_t k = 0; k < plans.size(); ++k) {
    if (!plans[k].plan.ok()) {
      // A member that cannot plan (its model predictions are not finite) leaves
      // the choice to the others; a cancel ends the call.
      if (absl::IsCancelled(plans[k].plan.status())) return plans[k].plan.status();
      if (first_error.ok()) first_error = plans[k].plan.status();
      continue;
    }
    Rollout rollout = RollOut(model, x0, plans[k].plan->inputs);
    const double score = criterion->Score(rollout);
    if (std::isfinite(score) && (best < 0 || score > best_score)) {
      best = static_cast<int>(k);
      best_score = score;
      best_rollout = std::move(rollout);
    }
  }
  if (best < 0) {
    return first_error.ok() ? absl::InternalError(
                                  "the model's predictions are not finite along any "
                                  "member's plan")
                            : first_error;
  }
  MemberPlan& chosen = plans[static_cast<size_t>(best)];
  if (chosen.plan->states.rows() == 0) {  // a signal: report its scored rollout
    chosen.plan->states = std::move(best_rollout.states);
    chosen.plan->variances = std::move(best_rollout.variances);
  }
  *summary = chosen.summary;
  summary->planned_by = members_[static_cast<size_t>(best)];
  return *std::move(chosen.plan);
}

}  // namespace excite::plan
