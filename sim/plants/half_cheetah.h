#ifndef EXCITE_SIM_PLANTS_HALF_CHEETAH_H_
#define EXCITE_SIM_PLANTS_HALF_CHEETAH_H_

#include <Eigen/Dense>
#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "sim/plants/mujoco_plant.h"

namespace excite::sim {

// Half-cheetah in MuJoCo (sim/plants/models/half_cheetah.xml, compiled into the
// binary). State x = (qpos, qvel), 18 numbers: rootx [m], rootz [m] (relative to the
// model's torso height 0.7 m), rooty [rad] (pitch), bthigh, bshin, bfoot, fthigh,
// fshin, ffoot [rad], then their rates. Input u = the six motors' controls in [-1, 1]
// (clamped). The floor makes the dynamics nonsmooth at contacts.
class HalfCheetah : public MujocoPlant {
 public:
  // INVALID_ARGUMENT if the embedded model does not load or has an unexpected shape.
  static absl::StatusOr<std::unique_ptr<HalfCheetah>> Create(double dt_s, int substeps);

  std::string name() const override { return "half_cheetah"; }
  int state_dim() const override { return 18; }

 protected:
  void StateToMujoco(const Eigen::VectorXd& x, mjtNum* qpos, mjtNum* qvel) const override;
  Eigen::VectorXd MujocoToState(const mjtNum* qpos, const mjtNum* qvel) const override;

 private:
  HalfCheetah(MjModelPtr model, double dt_s, int substeps);
};

}  // namespace excite::sim

#endif  // EXCITE_SIM_PLANTS_HALF_CHEETAH_H_
