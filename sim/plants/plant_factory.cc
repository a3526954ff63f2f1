#include "sim/plants/plant_factory.h"

#include <cmath>
#include <memory>
#include <string>
#include <utility>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "sim/plants/acrobot.h"
#include "sim/plants/cart_pole.h"
#include "sim/plants/dipc.h"
#include "sim/plants/duffing.h"
#include "sim/plants/half_cheetah.h"
#include "sim/plants/pendulum.h"
#include "sim/plants/two_link_arm.h"
#include "sim/plants/unicycle.h"

namespace excite::sim {
namespace {

absl::Status CheckPositive(double value, const char* field) {
  if (!(value > 0.0) || !std::isfinite(value)) {
    return absl::InvalidArgumentError(
        absl::StrCat("plant.", field, " must be positive and finite, got ", value));
  }
  return absl::OkStatus();
}

absl::Status CheckNonNegative(double value, const char* field) {
  if (!(value >= 0.0) || !std::isfinite(value)) {
    return absl::InvalidArgumentError(
        absl::StrCat("plant.", field, " must be non-negative and finite, got ", value));
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

absl::StatusOr<std::unique_ptr<Plant>> MakeTwoLink(const v1::PlantConfig& config) {
  const v1::TwoLinkParams& p = config.two_link();
  for (auto [value, field] : {std::pair{p.mass1_kg(), "two_link.mass1_kg"},
                              std::pair{p.mass2_kg(), "two_link.mass2_kg"},
                              std::pair{p.length1_m(), "two_link.length1_m"},
                              std::pair{p.length2_m(), "two_link.length2_m"},
                              std::pair{p.gravity(), "two_link.gravity"}}) {
    if (absl::Status s = CheckPositive(value, field); !s.ok()) return s;
  }
  for (auto [value, field] : {std::pair{p.damping1(), "two_link.damping1"},
                              std::pair{p.damping2(), "two_link.damping2"}}) {
    if (absl::Status s = CheckNonNegative(value, field); !s.ok()) return s;
  }
  TwoLinkArmParameters parameters;
  parameters.mass1_kg = p.mass1_kg();
  parameters.mass2_kg = p.mass2_kg();
  parameters.length1_m = p.length1_m();
  parameters.length2_m = p.length2_m();
  parameters.damping1 = p.damping1();
  parameters.damping2 = p.damping2();
  parameters.gravity = p.gravity();
  return std::make_unique<TwoLinkArm>(parameters, config.dt_s(), config.substeps());
}

absl::StatusOr<std::unique_ptr<Plant>> MakeUnicycle(const v1::PlantConfig& config) {
  const v1::UnicycleParams& p = config.unicycle();
  for (auto [value, field] :
       {std::pair{p.mass_kg(), "unicycle.mass_kg"},
        std::pair{p.yaw_inertia(), "unicycle.yaw_inertia"},
        std::pair{p.half_track_m(), "unicycle.half_track_m"},
        std::pair{p.lateral_damping(), "unicycle.lateral_damping"}}) {
    if (absl::Status s = CheckPositive(value, field); !s.ok()) return s;
  }
  for (auto [value, field] : {std::pair{p.forward_damping(), "unicycle.forward_damping"},
                              std::pair{p.yaw_damping(), "unicycle.yaw_damping"}}) {
    if (absl::Status s = CheckNonNegative(value, field); !s.ok()) return s;
  }
  UnicycleParameters parameters;
  parameters.mass_kg = p.mass_kg();
  parameters.yaw_inertia = p.yaw_inertia();
  parameters.half_track_m = p.half_track_m();
  parameters.forward_damping = p.forward_damping();
  parameters.lateral_damping = p.lateral_damping();
  parameters.yaw_damping = p.yaw_damping();
  return std::make_unique<Unicycle>(parameters, config.dt_s(), config.substeps());
}

absl::StatusOr<std::unique_ptr<Plant>> MakeAcrobot(const v1::PlantConfig& config) {
  const v1::AcrobotParams& p = config.acrobot();
  for (auto [value, field] :
       {std::pair{p.mass1_kg(), "acrobot.mass1_kg"},
        std::pair{p.mass2_kg(), "acrobot.mass2_kg"},
        std::pair{p.length1_m(), "acrobot.length1_m"},
        std::pair{p.com1_m(), "acrobot.com1_m"}, std::pair{p.com2_m(), "acrobot.com2_m"},
        std::pair{p.inertia1(), "acrobot.inertia1"},
        std::pair{p.inertia2(), "acrobot.inertia2"},
        std::pair{p.gravity(), "acrobot.gravity"}}) {
    if (absl::Status s = CheckPositive(value, field); !s.ok()) return s;
  }
  AcrobotParameters parameters;
  parameters.mass1_kg = p.mass1_kg();
  parameters.mass2_kg = p.mass2_kg();
  parameters.length1_m = p.length1_m();
  parameters.com1_m = p.com1_m();
  parameters.com2_m = p.com2_m();
  parameters.inertia1 = p.inertia1();
  parameters.inertia2 = p.inertia2();
  parameters.gravity = p.gravity();
  return std::make_unique<Acrobot>(parameters, config.dt_s(), config.substeps());
}

absl::StatusOr<std::unique_ptr<Plant>> MakeCartPole(const v1::PlantConfig& config) {
  const v1::CartPoleParams& p = config.cart_pole();
  for (auto [value, field] :
       {std::pair{p.cart_mass_kg(), "cart_pole.cart_mass_kg"},
        std::pair{p.pole_mass_kg(), "cart_pole.pole_mass_kg"},
        std::pair{p.pole_half_length_m(), "cart_pole.pole_half_length_m"},
        std::pair{p.gravity(), "cart_pole.gravity"}}) {
    if (absl::Status s = CheckPositive(value, field); !s.ok()) return s;
  }
  CartPoleParameters parameters;
  parameters.cart_mass_kg = p.cart_mass_kg();
  parameters.pole_mass_kg = p.pole_mass_kg();
  parameters.pole_half_length_m = p.pole_half_length_m();
  parameters.gravity = p.gravity();
  return std::make_unique<CartPole>(parameters, config.dt_s(), config.substeps());
}

absl::StatusOr<std::unique_ptr<Plant>> MakeDuffing(const v1::PlantConfig& config) {
  const v1::DuffingParams& p = config.duffing();
  if (absl::Status s = CheckNonNegative(p.damping(), "duffing.damping"); !s.ok())
    return s;
  for (auto [value, field] :
       {std::pair{p.linear_stiffness(), "duffing.linear_stiffness"},
        std::pair{p.cubic_stiffness(), "duffing.cubic_stiffness"}}) {
    if (!std::isfinite(value)) {
      return absl::InvalidArgumentError(
          absl::StrCat("plant.", field, " must be finite, got ", value));
    }
  }
  DuffingParameters parameters;
  parameters.damping = p.damping();
  parameters.linear_stiffness = p.linear_stiffness();
  parameters.cubic_stiffness = p.cubic_stiffness();
  return std::make_unique<Duffing>(parameters, config.dt_s(), config.substeps());
}

absl::StatusOr<std::unique_ptr<Plant>> MakeMujoco(const v1::PlantConfig& config) {
  const std::string& model = config.mujoco().model();
  if (model == "dipc") {
    absl::StatusOr<std::unique_ptr<Dipc>> plant =
        Dipc::Create(config.dt_s(), config.substeps());
    if (!plant.ok()) return plant.status();
    return std::unique_ptr<Plant>(*std::move(plant));
  }
  if (model == "half_cheetah") {
    absl::StatusOr<std::unique_ptr<HalfCheetah>> plant =
        HalfCheetah::Create(config.dt_s(), config.substeps());
    if (!plant.ok()) return plant.status();
    return std::unique_ptr<Plant>(*std::move(plant));
  }
  return absl::InvalidArgumentError(absl::StrCat(
      "plant.mujoco.model must be \"dipc\" or \"half_cheetah\", got \"", model, "\""));
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
    case v1::PlantConfig::kTwoLink:
      plant = MakeTwoLink(config);
      break;
    case v1::PlantConfig::kUnicycle:
      plant = MakeUnicycle(config);
      break;
    case v1::PlantConfig::kMujoco:
      plant = MakeMujoco(config);
      break;
    case v1::PlantConfig::kAcrobot:
      plant = MakeAcrobot(config);
      break;
    case v1::PlantConfig::kCartPole:
      plant = MakeCartPole(config);
      break;
    case v1::PlantConfig::kDuffing:
      plant = MakeDuffing(config);
      break;
    case v1::PlantConfig::MODEL_NOT_SET:
      return absl::InvalidArgumentError(
          "plant has no model: set one of the `model` fields (pendulum, two_link, "
          "unicycle, mujoco, acrobot, cart_pole, duffing)");
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
