#ifndef EXCITE_SERVER_PLAN_ENTROPY_OBJECTIVE_H_
#define EXCITE_SERVER_PLAN_ENTROPY_OBJECTIVE_H_

#include <Eigen/Dense>
#include <vector>

#include "server/plan/shooting_objective.h"

namespace excite::plan {

// Variances below this (data units squared) are treated as this value, so the
// logarithm never sees 0; below the floor the entropy's gradient is 0.
inline constexpr double kVarianceFloor = 1e-12;

// Differential entropy of independent Gaussians with the given variances, in nats:
// sum over all entries v of 1/2 log(2 pi e max(v, kVarianceFloor)). `variances`
// may be one point's row (1 x state_dim) or a whole horizon (M x state_dim).
double Entropy(const Eigen::MatrixXd& variances);

// Gradient of Entropy(variance) w.r.t. z for one point z with per-output
// variances `variance` (state_dim) and their Jacobian `variance_jacobian`
// (state_dim x z_dim, row j = d var_j / d z): sum_j 1 / (2 var_j) d var_j / d z.
// Returns a z_dim vector.
Eigen::VectorXd EntropyGradient(const Eigen::VectorXd& variance,
                                const Eigen::MatrixXd& variance_jacobian);

// The paper's objective (trajopt_optim) as a ShootingObjective: minus the summed
// entropy of the horizon, -Entropy(variance). Stateless.
class NegativeEntropyObjective final : public ShootingObjective {
 public:
  double Evaluate(const Eigen::MatrixXd& z, const Eigen::MatrixXd& mean,
                  const Eigen::MatrixXd& variance,
                  const std::vector<Eigen::MatrixXd>* mean_jacobians,
                  const std::vector<Eigen::MatrixXd>* variance_jacobians,
                  Eigen::MatrixXd* gradient) const override;
};

}  // namespace excite::plan

#endif  // EXCITE_SERVER_PLAN_ENTROPY_OBJECTIVE_H_
