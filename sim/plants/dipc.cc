#include "sim/plants/dipc.h"

#include <cmath>
#include <utility>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "sim/plants/models/embedded_models.h"

namespace excite::sim {

Dipc::Dipc(MjModelPtr model, double dt_s, int substeps)
    : MujocoPlant(std::move(model), dt_s, substeps) {}

absl::StatusOr<std::unique_ptr<Dipc>> Dipc::Create(double dt_s, int substeps) {
  absl::StatusOr<MjModelPtr> model = LoadMjcfFromString("dipc", EmbeddedMjcf("dipc"));
  if (!model.ok()) return model.status();
  if ((*model)->nq != 3 || (*model)->nv != 3 || (*model)->nu != 1) {
    return absl::InvalidArgumentError(absl::StrCat(
        "dipc model: expected nq = nv = 3 and nu = 1, got nq = ", (*model)->nq,
        ", nv = ", (*model)->nv, ", nu = ", (*model)->nu));
  }
  return std::unique_ptr<Dipc>(new Dipc(*std::move(model), dt_s, substeps));
}

Eigen::VectorXd Dipc::StateOf(double p, double t1, double t2, double p_dot, double t1_dot,
                              double t2_dot) {
  Eigen::VectorXd x(8);
  x << p, std::sin(t1), std::sin(t2), std::cos(t1), std::cos(t2), p_dot, t1_dot, t2_dot;
  return x;
}

void Dipc::StateToMujoco(const Eigen::VectorXd& x, mjtNum* qpos, mjtNum* qvel) const {
  qpos[0] = x(0);
  qpos[1] = std::atan2(x(1), x(3));
  qpos[2] = std::atan2(x(2), x(4));
  qvel[0] = x(5);
  qvel[1] = x(6);
  qvel[2] = x(7);
}

Eigen::VectorXd Dipc::MujocoToState(const mjtNum* qpos, const mjtNum* qvel) const {
  return StateOf(qpos[0], qpos[1], qpos[2], qvel[0], qvel[1], qvel[2]);
}

}  // namespace excite::sim
