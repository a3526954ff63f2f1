#ifndef EXCITE_SERVER_PLAN_ROLLOUT_H_
#define EXCITE_SERVER_PLAN_ROLLOUT_H_

#include <Eigen/Dense>

#include "server/gp/dynamics_predictor.h"

namespace excite::plan {

// An input sequence rolled out exactly through the model mean from x_0: any input
// sequence within the bounds, rolled out, is a feasible plan.
struct Rollout {
  Eigen::MatrixXd inputs;     // M x du: u_0 .. u_{M-1}
  Eigen::MatrixXd states;     // M x dx: x_0 .. x_{M-1}
  Eigen::MatrixXd means;      // M x dx: x_1 .. x_M (mean at (x_i, u_i))
  Eigen::MatrixXd variances;  // M x dx: latent variance at (x_i, u_i)
  bool valid = false;         // every number finite and of the right shape
};

// M sequential one-point Predict calls (no Jacobians).
Rollout RollOut(const gp::DynamicsPredictor& model, const Eigen::VectorXd& x0,
                const Eigen::MatrixXd& inputs);

// The points z_i = (x_i, u_i) of a rollout: M x (dx + du).
Eigen::MatrixXd PointsOf(const Rollout& rollout);

}  // namespace excite::plan

#endif  // EXCITE_SERVER_PLAN_ROLLOUT_H_
