#include "sim/sim_config.h"

#include <cmath>
#include <fstream>
#include <memory>
#include <sstream>
#include <utility>

#include "absl/strings/str_cat.h"
#include "google/protobuf/io/tokenizer.h"
#include "google/protobuf/text_format.h"
#include "server/service/config_validation.h"
#include "sim/plants/plant_factory.h"

namespace excite::sim {
namespace {

// Every strategy the server knows, by its command-line name.
constexpr std::pair<const char*, v1::Strategy> kStrategyNames[] = {
    {"rec", v1::STRATEGY_REC},       {"pa", v1::STRATEGY_PA},
    {"greedy", v1::STRATEGY_GREEDY}, {"prbs", v1::STRATEGY_PRBS},
    {"chirp", v1::STRATEGY_CHIRP},   {"random", v1::STRATEGY_RANDOM},
    {"sep", v1::STRATEGY_SEP},       {"mi", v1::STRATEGY_MI},
    {"roi", v1::STRATEGY_ROI},       {"optimistic", v1::STRATEGY_OPTIMISTIC},
};

// Collects text-format parse errors into one message.
class ErrorCollector : public google::protobuf::io::ErrorCollector {
 public:
  void AddError(int line, google::protobuf::io::ColumnNumber column,
                const std::string& message) override {
    absl::StrAppend(&errors_, errors_.empty() ? "" : "; ", line + 1, ":", column + 1,
                    ": ", message);
  }
  const std::string& errors() const { return errors_; }

 private:
  std::string errors_;
};

absl::Status CheckIntervals(
    const google::protobuf::RepeatedPtrField<v1::Interval>& bounds, int dim,
    const char* field) {
  if (bounds.size() != dim) {
    return absl::InvalidArgumentError(absl::StrCat(
        "session.", field, " has ", bounds.size(), " entries, expected ", dim));
  }
  for (int i = 0; i < dim; ++i) {
    const v1::Interval& b = bounds[i];
    if (!(b.lower() < b.upper()) || !std::isfinite(b.lower()) ||
        !std::isfinite(b.upper())) {
      return absl::InvalidArgumentError(
          absl::StrCat("session.", field, "[", i, "]: need finite lower < upper, got [",
                       b.lower(), ", ", b.upper(), "]"));
    }
  }
  return absl::OkStatus();
}

absl::Status CheckAtLeastOne(int64_t value, const char* field) {
  if (value < 1) {
    return absl::InvalidArgumentError(absl::StrCat(field, " must be >= 1, got ", value));
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<v1::SimConfig> ParseSimConfig(absl::string_view text) {
  v1::SimConfig config;
  ErrorCollector errors;
  google::protobuf::TextFormat::Parser parser;
  parser.RecordErrorsTo(&errors);
  if (!parser.ParseFromString(std::string(text), &config)) {
    return absl::InvalidArgumentError(
        absl::StrCat("SimConfig parse error: ", errors.errors()));
  }
  return config;
}

absl::StatusOr<v1::SimConfig> LoadSimConfig(const std::string& path) {
  std::ifstream file(path);
  if (!file) return absl::NotFoundError(absl::StrCat("cannot read config file ", path));
  std::stringstream text;
  text << file.rdbuf();
  absl::StatusOr<v1::SimConfig> config = ParseSimConfig(text.str());
  if (!config.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": ", config.status().message()));
  }
  return config;
}

absl::Status ValidateSimConfig(const v1::SimConfig& config) {
  // The session part by the server's own rules (the same code as on the wire).
  if (absl::StatusOr<v1::SessionConfig> session =
          service::ValidatedSessionConfig(config.session(), "session");
      !session.ok()) {
    return session.status();
  }
  absl::StatusOr<std::unique_ptr<Plant>> plant = MakePlant(config.plant());
  if (!plant.ok()) return plant.status();
  const v1::SessionConfig& session = config.session();
  if (session.state_dim() != (*plant)->state_dim() ||
      session.input_dim() != (*plant)->input_dim()) {
    return absl::InvalidArgumentError(
        absl::StrCat("session dims (state ", session.state_dim(), ", input ",
                     session.input_dim(), ") differ from the ", (*plant)->name(), "'s (",
                     (*plant)->state_dim(), ", ", (*plant)->input_dim(), ")"));
  }
  if (absl::Status s =
          CheckIntervals(session.input_bounds(), session.input_dim(), "input_bounds");
      !s.ok()) {
    return s;
  }
  if (absl::Status s = CheckIntervals(session.state_bounds(), session.state_dim(),
                                      "state_bounds (the region of interest)");
      !s.ok()) {
    return s;
  }
  if (!(session.noise().variance() > 0.0) || !std::isfinite(session.noise().variance())) {
    return absl::InvalidArgumentError(absl::StrCat(
        "session.noise.variance must be positive, got ", session.noise().variance()));
  }
  for (auto [value, field] :
       {std::pair<int64_t, const char*>{session.horizon(), "session.horizon"},
        {config.samples(), "samples"},
        {config.evaluation().points(), "evaluation.points"},
        {config.evaluation().every_samples(), "evaluation.every_samples"},
        {config.evaluation().marginal_bins(), "evaluation.marginal_bins"},
        {config.evaluation().joint_bins(), "evaluation.joint_bins"}}) {
    if (absl::Status s = CheckAtLeastOne(value, field); !s.ok()) return s;
  }
  return absl::OkStatus();
}

void ApplyOverrides(const SimOverrides& overrides, v1::SimConfig* config) {
  if (overrides.strategy.has_value()) {
    config->mutable_session()->set_strategy(*overrides.strategy);
  }
  if (overrides.samples.has_value()) config->set_samples(*overrides.samples);
  if (overrides.seed.has_value()) config->mutable_session()->set_seed(*overrides.seed);
}

absl::StatusOr<v1::Strategy> ParseStrategy(absl::string_view name) {
  for (const auto& [known, strategy] : kStrategyNames) {
    if (name == known) return strategy;
  }
  return absl::InvalidArgumentError(absl::StrCat(
      "unknown strategy \"", name,
      "\" (expected rec, pa, greedy, prbs, chirp, random, sep, mi, roi or optimistic)"));
}

std::string StrategyName(v1::Strategy strategy) {
  for (const auto& [known, value] : kStrategyNames) {
    if (strategy == value) return known;
  }
  return "rec";
}

}  // namespace excite::sim
