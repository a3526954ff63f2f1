#include "server/plan/steering_objective.h"

#include <utility>

namespace excite::plan {

SteeringObjective::SteeringObjective(Eigen::VectorXd target, Eigen::VectorXd weights)
    : target_(std::move(target)), weights_(std::move(weights)) {}

double SteeringObjective::Distance(const Eigen::VectorXd& x) const {
  return (x - target_).array().square().matrix().dot(weights_);
}

double SteeringObjective::Evaluate(
    const Eigen::MatrixXd& z, const Eigen::MatrixXd& mean,
    const Eigen::MatrixXd& /*variance*/,
    const std::vector<Eigen::MatrixXd>* mean_jacobians,
    const std::vector<Eigen::MatrixXd>* /*variance_jacobians*/,
    Eigen::MatrixXd* gradient) const {
  const Eigen::Index horizon = z.rows();
  const Eigen::Index dx = target_.size();
  if (gradient != nullptr) gradient->setZero(horizon, z.cols());
  double value = 0.0;
  for (Eigen::Index i = 1; i < horizon; ++i) {
    const Eigen::VectorXd d = z.row(i).head(dx).transpose() - target_;
    value += d.array().square().matrix().dot(weights_);
    if (gradient != nullptr) {
      gradient->row(i).head(dx) += 2.0 * d.cwiseProduct(weights_).transpose();
    }
  }
  if (horizon > 0) {
    const Eigen::Index last = horizon - 1;
    const Eigen::VectorXd d = mean.row(last).transpose() - target_;
    value += d.array().square().matrix().dot(weights_);
    if (gradient != nullptr) {
      // d/dz ||mean(z) - x*||_W^2 = 2 J^T W (mean - x*).
      gradient->row(last) +=
          2.0 * ((*mean_jacobians)[static_cast<size_t>(last)].transpose() *
                 d.cwiseProduct(weights_))
                    .transpose();
    }
  }
  return value;
}

}  // namespace excite::plan
