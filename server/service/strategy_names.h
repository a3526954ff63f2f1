#ifndef EXCITE_SERVER_SERVICE_STRATEGY_NAMES_H_
#define EXCITE_SERVER_SERVICE_STRATEGY_NAMES_H_

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "excite/v1/session_config.pb.h"
#include "server/plan/strategy.h"

namespace excite::service {

// A strategy's short name: the wire's enum name without STRATEGY_, in lower case
// (v1::STRATEGY_REC -> "rec"), which is also its plan::StrategyInfo::name.
// UNSPECIFIED and unknown values are "rec" (validation fills in rec).
std::string StrategyShortName(v1::Strategy strategy);

// The strategy named `name`: its short name or its enum name, in any case ("rec",
// "REC", "STRATEGY_REC"). INVALID_ARGUMENT listing the valid short names otherwise.
absl::StatusOr<v1::Strategy> ParseStrategyName(absl::string_view name);

// The engine's row of a wire strategy (UNSPECIFIED and unknown values: rec's,
// the default a validated config has).
const plan::StrategyInfo& EngineStrategy(v1::Strategy strategy);

// The wire value of an engine strategy (plan::Strategy::kRec -> v1::STRATEGY_REC).
v1::Strategy WireStrategy(plan::Strategy strategy);

// auto's engine chooser (UNSPECIFIED and unknown values: the portfolio).
plan::AutoChooser EngineChooser(v1::AutoConfig::Chooser chooser);

// The engine rows a config plans with: its strategy's, and for STRATEGY_AUTO its
// members' (as auto.members lists them; validation fills the default in) and,
// for the portfolio chooser, its criterion's (roi's, or mi's without state
// bounds).
std::vector<const plan::StrategyInfo*> StrategiesInUse(const v1::SessionConfig& config);

}  // namespace excite::service

#endif  // EXCITE_SERVER_SERVICE_STRATEGY_NAMES_H_
