#include "server/service/strategy_names.h"

#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"

namespace excite::service {
namespace {

constexpr absl::string_view kPrefix = "STRATEGY_";

}  // namespace

std::string StrategyShortName(v1::Strategy strategy) {
  if (strategy == v1::STRATEGY_UNSPECIFIED || !v1::Strategy_IsValid(strategy)) {
    strategy = v1::STRATEGY_REC;  // what validation fills in
  }
  std::string name = v1::Strategy_Name(strategy);
  if (absl::StartsWith(name, kPrefix)) name.erase(0, kPrefix.size());
  return absl::AsciiStrToLower(name);
}

absl::StatusOr<v1::Strategy> ParseStrategyName(absl::string_view name) {
  std::string wanted = absl::AsciiStrToLower(name);
  if (absl::StartsWith(wanted, "strategy_")) wanted.erase(0, kPrefix.size());
  std::vector<std::string> valid;
  const google::protobuf::EnumDescriptor* strategies = v1::Strategy_descriptor();
  for (int i = 0; i < strategies->value_count(); ++i) {
    const auto value = static_cast<v1::Strategy>(strategies->value(i)->number());
    if (value == v1::STRATEGY_UNSPECIFIED) continue;
    if (StrategyShortName(value) == wanted) return value;
    valid.push_back(StrategyShortName(value));
  }
  return absl::InvalidArgumentError(absl::StrCat("unknown strategy \"", name,
                                                 "\" (expected one of ",
                                                 absl::StrJoin(valid, ", "), ")"));
}

const plan::StrategyInfo& EngineStrategy(v1::Strategy strategy) {
  const plan::StrategyInfo* info = plan::FindStrategy(StrategyShortName(strategy));
  return info != nullptr ? *info : plan::InfoOf(plan::Strategy::kRec);
}

v1::Strategy WireStrategy(plan::Strategy strategy) {
  v1::Strategy wire = v1::STRATEGY_REC;
  const std::string name =
      absl::StrCat(kPrefix, absl::AsciiStrToUpper(plan::InfoOf(strategy).name));
  v1::Strategy_Parse(name, &wire);  // every row has its enum value (a test says so)
  return wire;
}

plan::AutoChooser EngineChooser(v1::AutoConfig::Chooser chooser) {
  return chooser == v1::AutoConfig::CHOOSER_BANDIT ? plan::AutoChooser::kBandit
                                                   : plan::AutoChooser::kPortfolio;
}

std::vector<const plan::StrategyInfo*> StrategiesInUse(const v1::SessionConfig& config) {
  std::vector<const plan::StrategyInfo*> used = {&EngineStrategy(config.strategy())};
  if (used.front()->strategy == plan::Strategy::kAuto) {
    for (int member : config.auto_().members()) {
      used.push_back(&EngineStrategy(static_cast<v1::Strategy>(member)));
    }
    // The portfolio judges plans with roi's objective (mi's without state bounds),
    // so it has their needs and reads roi's block.
    if (EngineChooser(config.auto_().chooser()) == plan::AutoChooser::kPortfolio) {
      const bool bounds = config.state_bounds_size() == config.state_dim();
      used.push_back(&plan::InfoOf(bounds ? plan::Strategy::kRoi : plan::Strategy::kMi));
    }
  }
  return used;
}

}  // namespace excite::service
