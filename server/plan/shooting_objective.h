#ifndef EXCITE_SERVER_PLAN_SHOOTING_OBJECTIVE_H_
#define EXCITE_SERVER_PLAN_SHOOTING_OBJECTIVE_H_

#include <Eigen/Dense>
#include <vector>

namespace excite::plan {

// What a multiple-shooting NLP (multiple_shooting_nlp.h) minimises: a function of
// the M points z_i = (x_i, u_i) of a horizon and of the model's prediction at each
// (mean(z_i), the predicted x_{i+1}, and the latent variance at z_i).
// Implementations: NegativeEntropyObjective (rec, pa, greedy) and
// SteeringObjective (sep).
class ShootingObjective {
 public:
  virtual ~ShootingObjective() = default;

  // z: M x z_dim; mean, variance: M x state_dim (row i predicted at z_i). If
  // `gradient` is not null, the Jacobian vectors are not null either (M entries,
  // state_dim x z_dim, as DynamicsPredictor::Predict returns them) and *gradient is
  // set to M x z_dim, row i = the total derivative of the value w.r.t. z_i
  // (directly and through mean.row(i) and variance.row(i)).
  virtual double Evaluate(const Eigen::MatrixXd& z, const Eigen::MatrixXd& mean,
                          const Eigen::MatrixXd& variance,
                          const std::vector<Eigen::MatrixXd>* mean_jacobians,
                          const std::vector<Eigen::MatrixXd>* variance_jacobians,
                          Eigen::MatrixXd* gradient) const = 0;
};

}  // namespace excite::plan

#endif  // EXCITE_SERVER_PLAN_SHOOTING_OBJECTIVE_H_
