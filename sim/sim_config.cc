#include "sim/sim_config.h"

#include <cmath>
#include <memory>
#include <utility>

#include "absl/strings/str_cat.h"
#include "server/service/config_text.h"
#include "server/service/config_validation.h"
#include "sim/plants/plant_factory.h"

namespace excite::sim {
namespace {

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
  if (absl::Status s = service::ParseTextProto(text, &config); !s.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat("SimConfig parse error: ", s.message()));
  }
  return config;
}

absl::StatusOr<v1::SimConfig> LoadSimConfig(const std::string& path) {
  absl::StatusOr<std::string> text = service::ReadTextFile(path);
  if (!text.ok()) {
    return absl::NotFoundError(absl::StrCat("cannot read config file ", path));
  }
  absl::StatusOr<v1::SimConfig> config = ParseSimConfig(*text);
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

Box BoxOf(const google::protobuf::RepeatedPtrField<v1::Interval>& bounds) {
  Box box{Eigen::VectorXd(bounds.size()), Eigen::VectorXd(bounds.size())};
  for (int i = 0; i < bounds.size(); ++i) {
    box.lower(i) = bounds[i].lower();
    box.upper(i) = bounds[i].upper();
  }
  return box;
}

}  // namespace excite::sim
