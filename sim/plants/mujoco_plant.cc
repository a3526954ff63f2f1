#include "sim/plants/mujoco_plant.h"

#include <utility>

namespace excite::sim {

MujocoPlant::MujocoPlant(MjModelPtr model, double dt_s, int substeps)
    : model_(std::move(model)), substeps_(substeps) {
  model_->opt.timestep = dt_s / substeps;
  data_.reset(mj_makeData(model_.get()));
}

Eigen::VectorXd MujocoPlant::Step(const Eigen::VectorXd& x,
                                  const Eigen::VectorXd& u) const {
  absl::MutexLock lock(&mu_);
  mjData* d = data_.get();
  mj_resetData(model_.get(), d);
  StateToMujoco(x, d->qpos, d->qvel);
  for (int i = 0; i < model_->nu; ++i) d->ctrl[i] = u(i);
  for (int i = 0; i < substeps_; ++i) mj_step(model_.get(), d);
  return MujocoToState(d->qpos, d->qvel);
}

}  // namespace excite::sim
