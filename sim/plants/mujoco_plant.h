#ifndef EXCITE_SIM_PLANTS_MUJOCO_PLANT_H_
#define EXCITE_SIM_PLANTS_MUJOCO_PLANT_H_

#include <mujoco/mujoco.h>

#include <Eigen/Dense>
#include <string>

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"
#include "sim/plants/mujoco_model.h"
#include "sim/plants/plant.h"

namespace excite::sim {

// A Plant simulated by MuJoCo. One Step: reset the simulation data (so a step depends
// on (x, u) only, not on the solver's warm start from earlier calls), write x into
// qpos/qvel (StateToMujoco), set ctrl = u (MuJoCo clamps it to the model's ctrlrange),
// call mj_step `substeps` times with the model's timestep dt_s / substeps, read the
// state back (MujocoToState). Subclasses define the state <-> (qpos, qvel) maps.
// Step is thread-safe (one mjData under a mutex: concurrent calls are serialised) and
// deterministic.
class MujocoPlant : public Plant {
 public:
  MujocoPlant(const MujocoPlant&) = delete;
  MujocoPlant& operator=(const MujocoPlant&) = delete;

  int input_dim() const override { return model_->nu; }
  Eigen::VectorXd Step(const Eigen::VectorXd& x, const Eigen::VectorXd& u) const override;

  // The compiled model (read-only; e.g. for body masses).
  const mjModel& model() const { return *model_; }
  double dt_s() const { return model_->opt.timestep * substeps_; }
  int substeps() const { return substeps_; }

 protected:
  // Takes ownership of `model`; sets its timestep to dt_s / substeps (both > 0).
  MujocoPlant(MjModelPtr model, double dt_s, int substeps);

  // Writes the state x into qpos (nq) and qvel (nv).
  virtual void StateToMujoco(const Eigen::VectorXd& x, mjtNum* qpos,
                             mjtNum* qvel) const = 0;
  // The state of (qpos, qvel).
  virtual Eigen::VectorXd MujocoToState(const mjtNum* qpos, const mjtNum* qvel) const = 0;

 private:
  MjModelPtr model_;
  int substeps_;
  mutable absl::Mutex mu_;
  MjDataPtr data_ ABSL_GUARDED_BY(mu_);
};

}  // namespace excite::sim

#endif  // EXCITE_SIM_PLANTS_MUJOCO_PLANT_H_
