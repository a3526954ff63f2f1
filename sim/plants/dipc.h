#ifndef EXCITE_SIM_PLANTS_DIPC_H_
#define EXCITE_SIM_PLANTS_DIPC_H_

#include <Eigen/Dense>
#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "sim/plants/mujoco_plant.h"

namespace excite::sim {

// Double inverted pendulum on a cart in MuJoCo (sim/plants/models/dipc.xml, compiled
// into the binary). State x = (p, sin t1, sin t2, cos t1, cos t2, p', t1', t2') with the
// cart position p [m] (rail |p| <= 2), t1 pole 1's angle from upright and t2 pole 2's
// angle relative to pole 1 [rad], as in Gym; angles enter MuJoCo as atan2(sin, cos).
// Both poles hang at t1 = pi, t2 = 0 (the stable equilibrium). Input u = the motor's
// control in [-1, 1] (force 500 u N on the cart; values outside are clamped).
class Dipc : public MujocoPlant {
 public:
  // INVALID_ARGUMENT if the embedded model does not load or has an unexpected shape.
  static absl::StatusOr<std::unique_ptr<Dipc>> Create(double dt_s, int substeps);

  std::string name() const override { return "dipc"; }
  int state_dim() const override { return 8; }
  // (sin t1, cos t1) and (sin t2, cos t2).
  std::vector<std::pair<int, int>> AnglePairs() const override {
    return {{1, 3}, {2, 4}};
  }

  // The state of cart position p, angles t1, t2 and their rates.
  static Eigen::VectorXd StateOf(double p, double t1, double t2, double p_dot,
                                 double t1_dot, double t2_dot);

 protected:
  void StateToMujoco(const Eigen::VectorXd& x, mjtNum* qpos, mjtNum* qvel) const override;
  Eigen::VectorXd MujocoToState(const mjtNum* qpos, const mjtNum* qvel) const override;

 private:
  Dipc(MjModelPtr model, double dt_s, int substeps);
};

}  // namespace excite::sim

#endif  // EXCITE_SIM_PLANTS_DIPC_H_
