#ifndef EXCITE_SERVER_GP_DYNAMICS_PREDICTOR_H_
#define EXCITE_SERVER_GP_DYNAMICS_PREDICTOR_H_

#include <Eigen/Dense>
#include <vector>

namespace excite::gp {

// What a planner needs from a probabilistic one-step dynamics model
// x_{k+1} ~ N(mean(z), variance(z)) with z = (x_k, u_k): implemented by
// DynamicsModel, and by analytic stand-ins in tests.
class DynamicsPredictor {
 public:
  virtual ~DynamicsPredictor() = default;

  virtual int state_dim() const = 0;
  virtual int input_dim() const = 0;
  int z_dim() const { return state_dim() + input_dim(); }

  // For m points z (m x z_dim, one per row): the predicted next state `mean`
  // (m x state_dim) and the latent variance of each output `variance`
  // (m x state_dim), in the units of the data. If the Jacobian outputs are not
  // null they are resized to m entries, each state_dim x z_dim:
  // (*mean_jacobians)[i](j, l) = d mean(i, j) / d z(i, l), same for variance.
  // Thread-safety: const calls may run concurrently.
  virtual void Predict(const Eigen::MatrixXd& z, Eigen::MatrixXd* mean,
                       Eigen::MatrixXd* variance,
                       std::vector<Eigen::MatrixXd>* mean_jacobians,
                       std::vector<Eigen::MatrixXd>* variance_jacobians) const = 0;
};

}  // namespace excite::gp

#endif  // EXCITE_SERVER_GP_DYNAMICS_PREDICTOR_H_
