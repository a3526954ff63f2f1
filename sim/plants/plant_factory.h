#ifndef EXCITE_SIM_PLANTS_PLANT_FACTORY_H_
#define EXCITE_SIM_PLANTS_PLANT_FACTORY_H_

#include <memory>

#include "absl/status/statusor.h"
#include "excite/v1/sim_config.pb.h"
#include "sim/plants/plant.h"

namespace excite::sim {

// Builds the plant a PlantConfig describes. INVALID_ARGUMENT (naming the field) if
// no model is set, dt_s or substeps are not positive, a model parameter is not
// positive (dampings may be 0, except the unicycle's lateral damping), mujoco.model is
// not "dipc" or "half_cheetah" (or its embedded MJCF fails to load: MuJoCo's message),
// or initial_state, when given, does not have the plant's state_dim entries or is not
// finite.
absl::StatusOr<std::unique_ptr<Plant>> MakePlant(const v1::PlantConfig& config);

}  // namespace excite::sim

#endif  // EXCITE_SIM_PLANTS_PLANT_FACTORY_H_
