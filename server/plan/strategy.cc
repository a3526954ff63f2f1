#include "server/plan/strategy.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>

#include "absl/strings/str_cat.h"
#include "server/plan/chirp_signal.h"
#include "server/plan/entropy_objective.h"
#include "server/plan/information_objectives.h"
#include "server/plan/optimistic_objective.h"
#include "server/plan/plan_types.h"
#include "server/plan/prbs_signal.h"
#include "server/plan/random_signal.h"
#include "server/plan/reference_set.h"

namespace excite::plan {
namespace {

using ObjectiveOr = absl::StatusOr<std::unique_ptr<ShootingObjective>>;

// Ipopt's obj_scaling_factor for -sum H. Entropy gradients are small (~0.1 per
// variable at typical starts), so with a limited-memory Hessian (initialised to
// the identity) Ipopt creeps along in tiny steps. Measured on the pendulum GP at
// n = 300, M = 15 (bench/plan, 12 rec steps, 2 starts): scaling 1 -> 84
// iterations per call, mean entropy -50.36; 10 -> 26, -50.36; 30 -> 18, -50.23;
// 100 -> 16, -50.23. The tolerance then applies to the scaled dual infeasibility,
// i.e. it is tighter, not looser.
constexpr double kEntropyScaling = 100.0;
// The same for mi (about 1-2 nats per horizon) and roi (a fraction, about 0.1-0.2
// per horizon): smaller values with smaller gradients. Measured on the same
// pendulum step (bench/plan BM_RecStep, 10 steps, another job running beside):
// mi 10 -> 105 iterations per call, 100 -> 33, 1000 -> 17, 10^4 -> 16 (objective
// 1.370, 1.373, 1.376, 1.382); roi 10 -> 113, 100 -> 75, 1000 -> 43, 10^4 -> 38
// (objective 0.1596, 0.1604, 0.1604, 0.1604).
constexpr double kInformationScaling = 1e4;

template <typename Objective>
ObjectiveOr Owned(absl::StatusOr<std::unique_ptr<Objective>> objective) {
  if (!objective.ok()) return objective.status();
  return std::unique_ptr<ShootingObjective>(*std::move(objective));
}

ObjectiveOr Entropy(const gp::DynamicsPredictor& /*model*/,
                    const PlanOptions& /*options*/, Eigen::MatrixXd* /*reference*/) {
  return std::unique_ptr<ShootingObjective>(new NegativeEntropyObjective());
}

ObjectiveOr MutualInformation(const gp::DynamicsPredictor& model,
                              const PlanOptions& /*options*/,
                              Eigen::MatrixXd* /*reference*/) {
  return Owned(NegativeMutualInformationObjective::Create(model));
}

ObjectiveOr VarianceReduction(const gp::DynamicsPredictor& model,
                              const PlanOptions& options, Eigen::MatrixXd* reference) {
  const Eigen::VectorXd& lower = options.state_lower;  // checked by the planner
  const Eigen::VectorXd& upper = options.state_upper;
  if (options.roi_reference_points < 1) {
    return absl::InvalidArgumentError("roi_reference_points must be >= 1");
  }
  if (reference->rows() != options.roi_reference_points) {
    Eigen::VectorXd z_lower(model.z_dim()), z_upper(model.z_dim());
    z_lower << lower, options.input_lower;
    z_upper << upper, options.input_upper;
    *reference =
        HaltonReferenceSet(z_lower, z_upper, options.roi_reference_points, options.seed);
  }
  return Owned(NegativeVarianceReductionObjective::Create(model, *reference));
}

ObjectiveOr OptimisticInformation(const gp::DynamicsPredictor& model,
                                  const PlanOptions& options,
                                  Eigen::MatrixXd* /*reference*/) {
  if (!(options.optimism_beta > 0.0) || !std::isfinite(options.optimism_beta)) {
    return absl::InvalidArgumentError("optimism_beta must be finite and > 0");
  }
  auto objective =
      NegativeLogVarianceRatioObjective::Create(model.ObservationNoiseVariances());
  if (!objective.ok()) return objective.status();
  return std::unique_ptr<ShootingObjective>(
      new NegativeLogVarianceRatioObjective(*std::move(objective)));
}

Eigen::MatrixXd Prbs(const PlanOptions& options, int64_t time_index) {
  return PrbsSignal(options.input_lower, options.input_upper,
                    options.signal.prbs_min_hold, options.seed, time_index,
                    options.horizon);
}

Eigen::MatrixXd Chirp(const PlanOptions& options, int64_t time_index) {
  ChirpParams params;
  params.start_frequency = options.signal.chirp_start_frequency;
  params.end_frequency = options.signal.chirp_end_frequency;
  params.period = options.signal.chirp_period;
  return ChirpSignal(options.input_lower, options.input_upper, params, time_index,
                     options.horizon);
}

Eigen::MatrixXd Random(const PlanOptions& options, int64_t time_index) {
  return RandomSignal(options.input_lower, options.input_upper,
                      options.signal.random_hold, options.seed, time_index,
                      options.horizon);
}

// A row: the fields every strategy has, then what sets it apart.
StrategyInfo Row(Strategy strategy, absl::string_view name, absl::string_view summary,
                 PlanMethod method) {
  StrategyInfo info;
  info.strategy = strategy;
  info.name = name;
  info.summary = summary;
  info.method = method;
  info.apply_all = method == PlanMethod::kSignal;
  return info;
}

std::array<StrategyInfo, 11> MakeTable() {
  std::array<StrategyInfo, 11> table;
  const auto at = [&table](Strategy s) -> StrategyInfo& {
    return table[static_cast<size_t>(s)];
  };
  at(Strategy::kRec) = Row(Strategy::kRec, "rec",
                           "receding horizon: plan M inputs maximising the summed "
                           "predictive entropy, apply the first, replan",
                           PlanMethod::kTrajectory);
  at(Strategy::kRec).objective_scaling = kEntropyScaling;
  at(Strategy::kRec).make_objective = &Entropy;

  at(Strategy::kPa) = Row(Strategy::kPa, "pa",
                          "plan and apply: plan M inputs as rec, apply all M, replan",
                          PlanMethod::kTrajectory);
  at(Strategy::kPa).apply_all = true;
  at(Strategy::kPa).objective_scaling = kEntropyScaling;
  at(Strategy::kPa).make_objective = &Entropy;

  at(Strategy::kGreedy) =
      Row(Strategy::kGreedy, "greedy", "rec with horizon 1", PlanMethod::kTrajectory);
  at(Strategy::kGreedy).fixed_horizon = 1;
  at(Strategy::kGreedy).objective_scaling = kEntropyScaling;
  at(Strategy::kGreedy).make_objective = &Entropy;

  at(Strategy::kPrbs) = Row(Strategy::kPrbs, "prbs",
                            "pseudo-random binary sequence between the input bounds "
                            "(model-free)",
                            PlanMethod::kSignal);
  at(Strategy::kPrbs).config_block = "signal";
  at(Strategy::kPrbs).make_signal = &Prbs;

  at(Strategy::kChirp) = Row(Strategy::kChirp, "chirp",
                             "linear swept-frequency sine between the input bounds "
                             "(model-free)",
                             PlanMethod::kSignal);
  at(Strategy::kChirp).config_block = "signal";
  at(Strategy::kChirp).make_signal = &Chirp;

  at(Strategy::kRandom) = Row(Strategy::kRandom, "random",
                              "uniform random inputs between the input bounds, each "
                              "held random_hold samples (model-free)",
                              PlanMethod::kSignal);
  at(Strategy::kRandom).config_block = "signal";
  at(Strategy::kRandom).make_signal = &Random;

  at(Strategy::kSep) = Row(Strategy::kSep, "sep",
                           "separated search and control: find z* of highest entropy "
                           "in the state x input box, steer towards x*, apply u*",
                           PlanMethod::kSeparated);
  at(Strategy::kSep).needs_state_bounds = true;
  at(Strategy::kSep).config_block = "sep";

  at(Strategy::kMi) =
      Row(Strategy::kMi, "mi", "rec maximising the horizon's joint mutual information",
          PlanMethod::kTrajectory);
  at(Strategy::kMi).needs_joint_covariances = true;
  at(Strategy::kMi).objective_scaling = kInformationScaling;
  at(Strategy::kMi).make_objective = &MutualInformation;

  at(Strategy::kRoi) = Row(Strategy::kRoi, "roi",
                           "rec maximising the variance removed over a reference set "
                           "of the state x input box",
                           PlanMethod::kTrajectory);
  at(Strategy::kRoi).needs_state_bounds = true;
  at(Strategy::kRoi).needs_joint_covariances = true;
  at(Strategy::kRoi).config_block = "roi";
  at(Strategy::kRoi).objective_scaling = kInformationScaling;
  at(Strategy::kRoi).make_objective = &VarianceReduction;

  at(Strategy::kOptimistic) = Row(Strategy::kOptimistic, "optimistic",
                                  "rec on optimistic (hallucinated) dynamics maximising "
                                  "the summed log(1 + var / noise) (OPAX)",
                                  PlanMethod::kTrajectory);
  at(Strategy::kOptimistic).optimistic_dynamics = true;
  at(Strategy::kOptimistic).config_block = "optimistic";
  at(Strategy::kOptimistic).objective_scaling = kEntropyScaling;
  at(Strategy::kOptimistic).make_objective = &OptimisticInformation;

  at(Strategy::kAuto) = Row(Strategy::kAuto, "auto",
                            "a choice among member strategies at every plan: a bandit "
                            "(EXP3) paid by the model's one-step error on the "
                            "transitions its plans produce, or a portfolio in which "
                            "every member plans and the plan removing the most "
                            "posterior variance wins; applies one input per plan",
                            PlanMethod::kMembers);
  at(Strategy::kAuto).config_block = "auto";
  return table;
}

const std::array<StrategyInfo, 11>& Table() {
  static const std::array<StrategyInfo, 11> table = MakeTable();
  return table;
}

}  // namespace

absl::Span<const StrategyInfo> Strategies() { return Table(); }

const StrategyInfo& InfoOf(Strategy strategy) {
  return Table()[static_cast<size_t>(strategy)];
}

bool CanBeAutoMember(Strategy strategy) {
  const StrategyInfo& info = InfoOf(strategy);
  return (info.method == PlanMethod::kTrajectory && !info.apply_all) ||
         info.method == PlanMethod::kSignal;
}

std::vector<Strategy> DefaultAutoMembers(bool has_state_bounds, AutoChooser chooser) {
  if (chooser == AutoChooser::kPortfolio) {
    return {Strategy::kRec, Strategy::kMi};
  }
  std::vector<Strategy> members = {Strategy::kRec, Strategy::kOptimistic};
  if (has_state_bounds) members.push_back(Strategy::kRoi);
  members.push_back(Strategy::kRandom);
  return members;
}

int FirstBadAutoMember(absl::Span<const Strategy> members, bool* repeated) {
  for (size_t i = 0; i < members.size(); ++i) {
    *repeated = std::find(members.begin(), members.begin() + i, members[i]) !=
                members.begin() + i;
    if (*repeated || !CanBeAutoMember(members[i])) return static_cast<int>(i);
  }
  return -1;
}

const StrategyInfo* FindStrategy(absl::string_view name) {
  for (const StrategyInfo& info : Table()) {
    if (info.name == name) return &info;
  }
  return nullptr;
}

}  // namespace excite::plan
