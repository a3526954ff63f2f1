#ifndef EXCITE_SERVER_PLAN_MEMBER_PORTFOLIO_H_
#define EXCITE_SERVER_PLAN_MEMBER_PORTFOLIO_H_

#include <Eigen/Dense>
#include <cstdint>
#include <memory>
#include <vector>

#include "absl/status/statusor.h"
#include "server/gp/dynamics_predictor.h"
#include "server/plan/plan_types.h"
#include "server/plan/planner.h"
#include "server/plan/rollout.h"
#include "server/plan/shooting_objective.h"

namespace excite::plan {

// auto's portfolio chooser (docs/bench_paper/auto-rule-2026-12-07.md): every
// member plans, one model criterion picks.

struct MemberPlan {
  absl::StatusOr<Plan> plan = absl::UnknownError("not planned");
  PlanSummary summary;
};

// Every planner's plan from x0. The caller must hold a planner slot (PlanSlot);
// further planners run at once on helper threads, each only while a slot is free
// at its start, the rest after on the caller's thread. A plan does not depend on
// the thread it ran on.
std::vector<MemberPlan> PlanEveryMember(std::vector<Planner>& planners,
                                        const gp::DynamicsPredictor& model,
                                        const Eigen::VectorXd& x0, int64_t time_index,
                                        const PlanLimits& limits);

// How much observing a plan's M points z_i = (x_i, u_i) (its mean trajectory)
// would teach the model, jointly: roi's objective, the share of the summed
// posterior variance over roi's reference set it would remove, when the options
// have state bounds; mi's mutual information (nats) otherwise. Reads the model
// at creation: it must not change while the criterion lives.
class PortfolioCriterion {
 public:
  // `reference`: roi's reference set, made on first use and kept across calls.
  // INVALID_ARGUMENT if the model has no joint covariances or noise variances.
  static absl::StatusOr<PortfolioCriterion> Create(const gp::DynamicsPredictor& model,
                                                   const PlanOptions& options,
                                                   Eigen::MatrixXd* reference);

  // Of a plan's inputs rolled out from x0 through the mean (RollOut): larger is
  // better; NaN if the rollout is not valid or a number is not finite.
  double Score(const Rollout& rollout) const;

 private:
  explicit PortfolioCriterion(std::unique_ptr<ShootingObjective> objective);
  std::shared_ptr<const ShootingObjective> objective_;
};

}  // namespace excite::plan

#endif  // EXCITE_SERVER_PLAN_MEMBER_PORTFOLIO_H_
