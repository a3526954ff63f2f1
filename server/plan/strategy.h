#ifndef EXCITE_SERVER_PLAN_STRATEGY_H_
#define EXCITE_SERVER_PLAN_STRATEGY_H_

#include <Eigen/Dense>
#include <cstdint>
#include <memory>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "absl/types/span.h"
#include "server/gp/dynamics_predictor.h"
#include "server/plan/shooting_objective.h"

namespace excite::plan {

// The exploration strategies (paper, Sections 4-6, and beyond it). What each one
// is lives in one row of the table below (StrategyInfo): the planner, the
// config validation, the clients' name parsing and the docs read it from there.
enum class Strategy {
  kRec,
  kPa,
  kGreedy,
  kPrbs,
  kChirp,
  kRandom,
  kSep,
  kMi,
  kRoi,
  kOptimistic,
  kAuto,
};

struct PlanOptions;

// How a strategy makes its plan.
enum class PlanMethod {
  // An open-loop signal of the sample index: the model is never evaluated, so
  // the strategy needs neither data nor a fitted model.
  kSignal,
  // sep: search z* = argmax H over X x U, steer towards x*, apply u*.
  kSeparated,
  // One multiple-shooting NLP maximising the strategy's objective along the
  // horizon (Ipopt).
  kTrajectory,
  // auto: a choice among member strategies per call (auto_planner.h: a bandit
  // draws one, or a portfolio of all is judged); the plan's first input is applied.
  kMembers,
};

// The open-loop signal of a kSignal strategy: inputs for samples
// time_index .. time_index + options.horizon - 1 (horizon x input_dim).
using SignalMaker = Eigen::MatrixXd (*)(const PlanOptions& options, int64_t time_index);

// The objective of a kTrajectory strategy on `model` (it reads the model: made
// per call). `reference` is a cache the planner keeps across calls (roi's
// reference set); INVALID_ARGUMENT if the options or the model do not suit it.
using ObjectiveMaker = absl::StatusOr<std::unique_ptr<ShootingObjective>> (*)(
    const gp::DynamicsPredictor& model, const PlanOptions& options,
    Eigen::MatrixXd* reference);

struct StrategyInfo {
  Strategy strategy = Strategy::kRec;
  // Short lower-case name: "rec". The wire's enum value is STRATEGY_ + its upper
  // case (v1::STRATEGY_REC); clients accept either.
  absl::string_view name;
  // One line for usage texts and the docs.
  absl::string_view summary;
  PlanMethod method = PlanMethod::kTrajectory;
  // Needs state_dim state bounds (sep: its search box; roi: its reference set).
  bool needs_state_bounds = false;
  // Needs the exact GP's joint covariances, so its sessions never turn sparse.
  bool needs_joint_covariances = false;
  // > 0: the horizon is forced to this (greedy: 1); 0: the config's.
  int fixed_horizon = 0;
  // Inputs of a plan applied before planning again: all of them (pa and the
  // signals) or the first only.
  bool apply_all = false;
  // Plans on optimistic dynamics x_{i+1} = mean + beta sd o eta_i whose
  // hallucinated controls eta_i in [-1, 1]^dx the NLP also chooses (OPAX).
  bool optimistic_dynamics = false;
  // The config block whose defaults the strategy reads ("signal", "sep",
  // "roi", "optimistic", "auto"), or empty.
  absl::string_view config_block;
  // kTrajectory: Ipopt's obj_scaling_factor for -objective (planner.cc says
  // how each was measured) and the objective. kSignal: the signal.
  double objective_scaling = 0.0;
  ObjectiveMaker make_objective = nullptr;
  SignalMaker make_signal = nullptr;
};

// Every strategy, in the order of the enum.
absl::Span<const StrategyInfo> Strategies();
const StrategyInfo& InfoOf(Strategy strategy);
// The row named `name` ("rec"), or nullptr.
const StrategyInfo* FindStrategy(absl::string_view name);

// Whether `strategy` may be one of auto's members: the receding-horizon
// trajectory strategies and the signals. Not pa (inside auto it applies one input,
// so it is rec), sep (its plan must be applied whole) or auto itself.
bool CanBeAutoMember(Strategy strategy);
// How auto picks each call's plan: a bandit draws one member
// (docs/bench_paper/auto-rule-2026-12-06.md), or every member plans and one model
// criterion picks (a portfolio, docs/bench_paper/auto-rule-2026-12-07.md).
enum class AutoChooser { kBandit, kPortfolio };

// auto's members when the config names none. The bandit: rec, optimistic, roi
// (only with state bounds, which it needs) and random, the one member that does
// not use the model. The portfolio: rec and mi, which plan in about rec's time
// (docs/bench_paper/auto-2026-12-07.md: with random as a third member it learned
// less on the five paper systems).
std::vector<Strategy> DefaultAutoMembers(bool has_state_bounds, AutoChooser chooser);
// The index of the first of `members` that auto cannot take: one that cannot be a
// member (*repeated = false) or one named before (*repeated = true); -1 if none.
int FirstBadAutoMember(absl::Span<const Strategy> members, bool* repeated);

// True for the strategies that never evaluate the model (prbs, chirp, random).
inline bool IsModelFree(Strategy strategy) {
  return InfoOf(strategy).method == PlanMethod::kSignal;
}

}  // namespace excite::plan

#endif  // EXCITE_SERVER_PLAN_STRATEGY_H_
