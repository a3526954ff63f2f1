#include "server/plan/plan_types.h"

#include <cmath>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"

namespace excite::plan {
namespace {

absl::Status ValidateSignal(const SignalOptions& signal, Strategy strategy) {
  switch (strategy) {
    case Strategy::kPrbs:
      if (signal.prbs_min_hold < 1) {
        return absl::InvalidArgumentError("prbs_min_hold must be >= 1");
      }
      break;
    case Strategy::kChirp:
      if (signal.chirp_period < 1 || !std::isfinite(signal.chirp_start_frequency) ||
          !std::isfinite(signal.chirp_end_frequency)) {
        return absl::InvalidArgumentError(
            "chirp_period must be >= 1 and the chirp frequencies finite");
      }
      break;
    case Strategy::kRandom:
      if (signal.random_hold < 1) {
        return absl::InvalidArgumentError("random_hold must be >= 1");
      }
      break;
    default:
      break;
  }
  return absl::OkStatus();
}

}  // namespace

std::vector<Strategy> PlanOptions::AutoMembers() const {
  return auto_members.empty() ? DefaultAutoMembers(state_lower.size() > 0, auto_chooser)
                              : auto_members;
}

absl::Status PlanOptions::Validate(int state_dim, int input_dim) const {
  const Eigen::VectorXd& lower = input_lower;
  const Eigen::VectorXd& upper = input_upper;
  if (lower.size() != input_dim || upper.size() != input_dim) {
    return absl::InvalidArgumentError(
        absl::StrCat("input bounds have ", lower.size(), " and ", upper.size(),
                     " entries, the model's input has ", input_dim));
  }
  if (!lower.allFinite() || !upper.allFinite() || (lower.array() > upper.array()).any()) {
    return absl::InvalidArgumentError("input bounds must be finite with lower <= upper");
  }
  const StrategyInfo& info = InfoOf(strategy);
  if (info.fixed_horizon == 0 && horizon < 1) {
    return absl::InvalidArgumentError("horizon must be >= 1");
  }
  if (max_iterations < 0 || restarts < 0 || !(tolerance > 0.0)) {
    return absl::InvalidArgumentError(
        "max_iterations and restarts must be >= 0, tolerance > 0");
  }
  const SafeBox& box = safe_box;
  if (box.active() && (box.lower.size() != state_dim || box.upper.size() != state_dim ||
                       !box.lower.allFinite() || !box.upper.allFinite() ||
                       !(box.lower.array() < box.upper.array()).all() ||
                       !(box.margin >= 0.0) || !std::isfinite(box.margin))) {
    return absl::InvalidArgumentError(
        absl::StrCat("the safe box needs state_dim (", state_dim,
                     ") finite intervals with lower < upper and a finite margin >= 0"));
  }
  if (absl::Status s = ValidateSignal(signal, strategy); !s.ok()) {
    return s;
  }
  if (strategy == Strategy::kAuto) {
    const std::vector<Strategy> members = AutoMembers();
    bool repeated = false;
    if (const int bad = FirstBadAutoMember(members, &repeated); bad >= 0) {
      const absl::string_view name = InfoOf(members[static_cast<size_t>(bad)]).name;
      return absl::InvalidArgumentError(
          repeated ? absl::StrCat(name, " is named twice among auto's members")
                   : absl::StrCat(name,
                                  " cannot be a member of auto (pa, sep and auto "
                                  "cannot; the others can)"));
    }
    for (const Strategy member : members) {
      PlanOptions own = *this;
      own.strategy = member;
      own.auto_members.clear();
      if (absl::Status s = own.Validate(state_dim, input_dim); !s.ok()) {
        return absl::InvalidArgumentError(
            absl::StrCat("auto's member ", InfoOf(member).name, ": ", s.message()));
      }
    }
  }
  if (info.needs_state_bounds) {
    if (state_lower.size() != state_dim || state_upper.size() != state_dim ||
        !state_lower.allFinite() || !state_upper.allFinite() ||
        !(state_lower.array() < state_upper.array()).all()) {
      return absl::InvalidArgumentError(
          absl::StrCat(info.name, " needs state bounds: state_dim (", state_dim,
                       ") finite intervals with lower < upper, got ", state_lower.size(),
                       " and ", state_upper.size(), " entries"));
    }
  }
  return absl::OkStatus();
}

}  // namespace excite::plan
