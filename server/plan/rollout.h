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

// Optimistic (hallucinated) dynamics: x_{i+1} = mean(z_i) + beta sd(z_i) o eta_i,
// with sd the latent standard deviation (floored at sqrt(kVarianceFloor)) and
// eta_i in [-1, 1]^dx, row i of `eta` ((M - 1) x dx; rows past M - 1 unused).
struct Hallucination {
  double beta = 0.0;
  Eigen::MatrixXd eta;
};

// Rolls the inputs out from x0, through the mean (M one-point mean-only Predict
// calls, then one batched call for the variances), or through the optimistic
// dynamics if `hallucination` is given (M one-point calls with variances; then
// `states` is the hallucinated trajectory and `means` still the mean at each
// point). No Jacobians.
Rollout RollOut(const gp::DynamicsPredictor& model, const Eigen::VectorXd& x0,
                const Eigen::MatrixXd& inputs,
                const Hallucination* hallucination = nullptr);

// The points z_i = (x_i, u_i) of a rollout: M x (dx + du).
Eigen::MatrixXd PointsOf(const Rollout& rollout);

}  // namespace excite::plan

#endif  // EXCITE_SERVER_PLAN_ROLLOUT_H_
