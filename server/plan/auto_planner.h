#ifndef EXCITE_SERVER_PLAN_AUTO_PLANNER_H_
#define EXCITE_SERVER_PLAN_AUTO_PLANNER_H_

#include <Eigen/Dense>
#include <cstdint>
#include <optional>
#include <vector>

#include "absl/status/statusor.h"
#include "server/gp/dynamics_predictor.h"
#include "server/plan/member_bandit.h"
#include "server/plan/plan_types.h"
#include "server/plan/planner.h"

namespace excite::plan {

// EXP3's exploration share for auto: EXP3's choice sqrt(K ln K / ((e - 1) T)) for
// K = 4 members and T = 300 plans (the paper's budget) is 0.104
// (docs/bench_paper/auto-rule-2026-12-06.md).
inline constexpr double kAutoGamma = 0.1;

// The auto strategy: a choice among member strategies (options.auto_members, or
// DefaultAutoMembers), each planning with its own Planner; only the chosen plan's
// first input is applied. Two choosers (options.auto_chooser):
//  - kBandit: a bandit (MemberBandit) draws one member, which plans. When the next
//    call starts exactly one sample later, its state is the plant's answer to that
//    input, and the member is paid by the model's one-step error on that
//    transition, predicted before the transition existed (SurpriseScale): members
//    are paid for taking the plant where the model is wrong, which needs no ground
//    truth. A predicted x0 (the plant runs ahead of the plans) neither pays nor is
//    paid.
//  - kPortfolio: every member plans (member_portfolio.h, at once while planner
//    slots are free), and the plan whose mean trajectory would teach the model most
//    (PortfolioCriterion) wins.
// Not thread-safe.
class AutoPlanner {
 public:
  explicit AutoPlanner(const PlanOptions& options);

  absl::StatusOr<Plan> PlanInputs(const gp::DynamicsPredictor& model,
                                  const Eigen::VectorXd& x0, int64_t time_index,
                                  const PlanLimits& limits, bool x0_measured,
                                  PlanSummary* summary);

  const std::vector<Strategy>& members() const { return members_; }
  Eigen::VectorXd Probabilities() const { return bandit_.Probabilities(); }

 private:
  // The last plan's first transition, to be scored by the next call.
  struct Pending {
    int member = 0;
    double probability = 1.0;
    int64_t time_index = 0;
    Eigen::VectorXd predicted;  // mean of the next state under the model then
  };
  void ScorePending(const Eigen::VectorXd& x0, int64_t time_index);
  // The member's plan and summary, kBandit.
  absl::StatusOr<Plan> PlanByBandit(const gp::DynamicsPredictor& model,
                                    const Eigen::VectorXd& x0, int64_t time_index,
                                    const PlanLimits& limits, bool x0_measured,
                                    PlanSummary* summary);
  absl::StatusOr<Plan> PlanByPortfolio(const gp::DynamicsPredictor& model,
                                       const Eigen::VectorXd& x0, int64_t time_index,
                                       const PlanLimits& limits, PlanSummary* summary);

  PlanOptions options_;
  uint64_t seed_;
  std::vector<int> angle_dims_;
  std::vector<Strategy> members_;
  std::vector<Planner> planners_;
  MemberBandit bandit_;
  SurpriseScale surprise_;
  std::optional<Pending> pending_;
  uint64_t calls_ = 0;
  Eigen::MatrixXd reference_;  // the portfolio criterion's (roi's) reference set
};

}  // namespace excite::plan

#endif  // EXCITE_SERVER_PLAN_AUTO_PLANNER_H_
