#ifndef EXCITE_SIM_PLANTS_MUJOCO_MODEL_H_
#define EXCITE_SIM_PLANTS_MUJOCO_MODEL_H_

#include <mujoco/mujoco.h>

#include <memory>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace excite::sim {

// Deleters so that mjModel and mjData are owned by std::unique_ptr (RAII).
struct MjModelDeleter {
  void operator()(mjModel* model) const { mj_deleteModel(model); }
};
struct MjDataDeleter {
  void operator()(mjData* data) const { mj_deleteData(data); }
};
using MjModelPtr = std::unique_ptr<mjModel, MjModelDeleter>;
using MjDataPtr = std::unique_ptr<mjData, MjDataDeleter>;

// Compiles MJCF text held in memory (through a MuJoCo virtual file system: nothing is
// read from disk). `name` is only used for the VFS file name and in messages.
// INVALID_ARGUMENT with MuJoCo's parser/compiler message if the model does not load.
// Thread-safe (loads are serialised: MuJoCo's parser keeps global state).
absl::StatusOr<MjModelPtr> LoadMjcfFromString(absl::string_view name,
                                              absl::string_view mjcf);

}  // namespace excite::sim

#endif  // EXCITE_SIM_PLANTS_MUJOCO_MODEL_H_
