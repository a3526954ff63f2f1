#include "sim/plants/half_cheetah.h"

#include <utility>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "sim/plants/models/embedded_models.h"

namespace excite::sim {

HalfCheetah::HalfCheetah(MjModelPtr model, double dt_s, int substeps)
    : MujocoPlant(std::move(model), dt_s, substeps) {}

absl::StatusOr<std::unique_ptr<HalfCheetah>> HalfCheetah::Create(double dt_s,
                                                                 int substeps) {
  absl::StatusOr<MjModelPtr> model =
      LoadMjcfFromString("half_cheetah", EmbeddedMjcf("half_cheetah"));
  if (!model.ok()) return model.status();
  if ((*model)->nq != 9 || (*model)->nv != 9 || (*model)->nu != 6) {
    return absl::InvalidArgumentError(absl::StrCat(
        "half_cheetah model: expected nq = nv = 9 and nu = 6, got nq = ", (*model)->nq,
        ", nv = ", (*model)->nv, ", nu = ", (*model)->nu));
  }
  return std::unique_ptr<HalfCheetah>(new HalfCheetah(*std::move(model), dt_s, substeps));
}

void HalfCheetah::StateToMujoco(const Eigen::VectorXd& x, mjtNum* qpos,
                                mjtNum* qvel) const {
  for (int i = 0; i < 9; ++i) {
    qpos[i] = x(i);
    qvel[i] = x(9 + i);
  }
}

Eigen::VectorXd HalfCheetah::MujocoToState(const mjtNum* qpos, const mjtNum* qvel) const {
  Eigen::VectorXd x(18);
  for (int i = 0; i < 9; ++i) {
    x(i) = qpos[i];
    x(9 + i) = qvel[i];
  }
  return x;
}

}  // namespace excite::sim
