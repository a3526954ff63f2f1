#ifndef EXCITE_SERVER_PLAN_ROLLOUT_H_
#define EXCITE_SERVER_PLAN_ROLLOUT_H_

#include <Eigen/Dense>
#include <vector>

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

// The state distribution along an input sequence (see PropagateLinearised).
struct PropagatedTrajectory {
  Eigen::MatrixXd means;                     // (M + 1) x dx: x_0 .. x_M
  std::vector<Eigen::MatrixXd> covariances;  // M + 1 of dx x dx
  bool valid = false;                        // every number finite
};

// x_k's mean and covariance from x_0 ~ N(x0, x0_covariance) along `inputs`
// (M x du), propagated through the GP by linearising its mean, as an extended
// Kalman filter predicts: mu_{k+1} = m(mu_k, u_k) and Sigma_{k+1} = A_k Sigma_k
// A_k^T + diag(v(mu_k, u_k) + step_noise), A_k = d m / d x at (mu_k, u_k), m and
// v the GP's mean and latent variance. Each step's GP value is taken as a fresh
// draw (no correlation between steps), as moment matching (PILCO) also does.
// step_noise: dx entries (the observation noise, to predict measurements) or
// empty (none). M one-point Predict calls with mean Jacobians.
PropagatedTrajectory PropagateLinearised(const gp::DynamicsPredictor& model,
                                         const Eigen::VectorXd& x0,
                                         const Eigen::MatrixXd& x0_covariance,
                                         const Eigen::MatrixXd& inputs,
                                         const Eigen::VectorXd& step_noise);

// The points z_i = (x_i, u_i) of a rollout: M x (dx + du).
Eigen::MatrixXd PointsOf(const Rollout& rollout);

}  // namespace excite::plan

#endif  // EXCITE_SERVER_PLAN_ROLLOUT_H_
