#ifndef EXCITE_SERVER_PLAN_STEERING_OBJECTIVE_H_
#define EXCITE_SERVER_PLAN_STEERING_OBJECTIVE_H_

#include <Eigen/Dense>
#include <vector>

#include "server/plan/shooting_objective.h"

namespace excite::plan {

// sep's steering cost: the weighted squared distance of every state the horizon
// reaches to a target x*,
//   J = sum_{i=1}^{M-1} ||x_i - x*||_W^2 + ||mean(z_{M-1}) - x*||_W^2,
// W = diag(weights). In a multiple-shooting NLP x_1..x_{M-1} are decision variables
// (equal to the mean of the previous point once feasible) and the last term is the
// terminal state x_M, so on a rollout J = sum_{i=1}^{M} ||x_i - x*||_W^2: a running
// plus terminal cost that rewards getting close early and staying close. x_0 is
// given and not counted.
class SteeringObjective final : public ShootingObjective {
 public:
  // target: state_dim; weights: state_dim entries > 0 (e.g. 1 / half-width^2 of
  // the region of interest, so every dimension counts in the same units).
  SteeringObjective(Eigen::VectorXd target, Eigen::VectorXd weights);

  double Evaluate(const Eigen::MatrixXd& z, const Eigen::MatrixXd& mean,
                  const Eigen::MatrixXd& variance,
                  const std::vector<Eigen::MatrixXd>* mean_jacobians,
                  const std::vector<Eigen::MatrixXd>* variance_jacobians,
                  Eigen::MatrixXd* gradient) const override;

  // ||x - x*||_W^2.
  double Distance(const Eigen::VectorXd& x) const;

  const Eigen::VectorXd& target() const { return target_; }

 private:
  Eigen::VectorXd target_;
  Eigen::VectorXd weights_;
};

}  // namespace excite::plan

#endif  // EXCITE_SERVER_PLAN_STEERING_OBJECTIVE_H_
