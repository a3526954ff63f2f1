#include "sim/plants/plant_factory.h"

#include <cmath>
#include <memory>
#include <utility>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "sim/plants/pendulum.h"

namespace excite::sim {
namespace {

absl::Status CheckPositive(double value, const char* field) {
  if (!(value > 0.0) || !std::isfinite(value)) {
    return absl::InvalidArgumentError(
        absl::StrCat("plant.", field, " must be positive and finite, got ", value));
  }
  return absl::OkStatus();
}

absl::StatusOr<std::unique_ptr<Plant>> MakePendulum(const v1::PlantConfig& config) {
  const v1::PendulumParams& p = config.pendulum();
  for (auto [value, field] : {std::pair{p.mass_kg(), "pendulum.mass_kg"},
                              std::pair{p.length_m(), "pendulum.length_m"},
                              std::pair{p.gravity(), "pendulum.gravity"}}) {
    if (absl::Status s = CheckPositive(value, field); !s.ok()) return s;
  }
  if (!(p.damping() >= 0.0) || !std::isfinite(p.damping())) {
    return absl::InvalidArgumentError(absl::StrCat(
        "plant.pendulum.damping must be non-negative and finite, got ", p.damping()));
  }
  PendulumParameters parameters;
  parameters.mass_kg = p.mass_kg();
  parameters.length_m = p.length_m();
  parameters.damping = p.damping();
  parameters.gravity = p.gravity();
  return std::make_unique<Pendulum>(parameters, config.dt_s(), config.substeps());
}

}  // namespace

absl::StatusOr<std::unique_ptr<Plant>> MakePlant(const v1::PlantConfig& config) {
  if (absl::Status s = CheckPositive(config.dt_s(), "dt_s"); !s.ok()) return s;
  if (config.substeps() < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("plant.substeps must be >= 1, got ", config.substeps()));
  }
  absl::StatusOr<std::unique_ptr<Plant>> plant;
  switch (config.model_case()) {
    case v1::PlantConfig::kPendulum:
      plant = MakePendulum(config);
      break;
    case v1::PlantConfig::MODEL_NOT_SET:
      return absl::InvalidArgumentError(
          "plant has no model: set one of the `model` fields (e.g. pendulum)");
  }
  if (!plant.ok()) return plant.status();
  if (config.initial_state_size() != 0) {
    if (config.initial_state_size() != (*plant)->state_dim()) {
      return absl::InvalidArgumentError(absl::StrCat(
          "plant.initial_state has ", config.initial_state_size(), " entries, the ",
          (*plant)->name(), " has state_dim ", (*plant)->state_dim()));
    }
    for (double v : config.initial_state()) {
      if (!std::isfinite(v)) {
        return absl::InvalidArgumentError("plant.initial_state must be finite");
      }
    }
  }
  return plant;
}

}  // namespace excite::sim
