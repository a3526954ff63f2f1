#include "server/plan/member_portfolio.h"

#include <atomic>
#include <exception>
#include <limits>
#include <thread>
#include <utility>

#include "absl/strings/str_cat.h"
#include "server/plan/plan_slots.h"
#include "server/plan/strategy.h"

namespace excite::plan {

std::vector<MemberPlan> PlanEveryMember(std::vector<Planner>& planners,
                                        const gp::DynamicsPredictor& model,
                                        const Eigen::VectorXd& x0, int64_t time_index,
                                        const PlanLimits& limits) {
  std::vector<MemberPlan> out(planners.size());
  std::atomic<size_t> next{0};
  // Plans members until none is left; a helper thread's exception (bad_alloc)
  // becomes its member's status instead of ending the process.
  const auto plan_the_rest = [&] {
    for (size_t k = next++; k < planners.size(); k = next++) {
      try {
        out[k].plan =
            planners[k].PlanInputs(model, x0, time_index, limits, &out[k].summary);
      } catch (const std::exception& e) {
        out[k].plan = absl::ResourceExhaustedError(
            absl::StrCat("auto's member ", InfoOf(planners[k].options().strategy).name,
                         " failed: ", e.what()));
      }
    }
  };
  std::vector<std::thread> helpers;
  for (size_t h = 1; h < planners.size(); ++h) {
    helpers.emplace_back([&] {
      PlanSlot slot;
      if (slot.TryAcquire()) plan_the_rest();
    });
  }
  plan_the_rest();
  for (std::thread& helper : helpers) helper.join();
  return out;
}

PortfolioCriterion::PortfolioCriterion(std::unique_ptr<ShootingObjective> objective)
    : objective_(std::move(objective)) {}

absl::StatusOr<PortfolioCriterion> PortfolioCriterion::Create(
    const gp::DynamicsPredictor& model, const PlanOptions& options,
    Eigen::MatrixXd* reference) {
  const Strategy criterion =
      options.state_lower.size() > 0 ? Strategy::kRoi : Strategy::kMi;
  absl::StatusOr<std::unique_ptr<ShootingObjective>> objective =
      InfoOf(criterion).make_objective(model, options, reference);
  if (!objective.ok()) return objective.status();
  return PortfolioCriterion(*std::move(objective));
}

double PortfolioCriterion::Score(const Rollout& rollout) const {
  if (!rollout.valid) return std::numeric_limits<double>::quiet_NaN();
  // Both objectives are minus the information.
  return -objective_->Evaluate(PointsOf(rollout), rollout.means, rollout.variances,
                               nullptr, nullptr, nullptr);
}

}  // namespace excite::plan
