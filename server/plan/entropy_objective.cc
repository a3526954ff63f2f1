#include "server/plan/entropy_objective.h"

#include <cmath>

namespace excite::plan {
namespace {

// log(2 pi e).
constexpr double kLogTwoPiE = 2.8378770664093453;

}  // namespace

double Entropy(const Eigen::MatrixXd& variances) {
  double sum = 0.0;
  for (Eigen::Index i = 0; i < variances.rows(); ++i) {
    for (Eigen::Index j = 0; j < variances.cols(); ++j) {
      const double v = variances(i, j);
      // !(v >= floor) also catches NaN.
      sum += 0.5 * (kLogTwoPiE + std::log(!(v >= kVarianceFloor) ? kVarianceFloor : v));
    }
  }
  return sum;
}

Eigen::VectorXd EntropyGradient(const Eigen::VectorXd& variance,
                                const Eigen::MatrixXd& variance_jacobian) {
  Eigen::VectorXd gradient = Eigen::VectorXd::Zero(variance_jacobian.cols());
  for (Eigen::Index j = 0; j < variance.size(); ++j) {
    const double v = variance(j);
    if (!(v >= kVarianceFloor)) continue;  // floored: locally constant
    gradient += (0.5 / v) * variance_jacobian.row(j).transpose();
  }
  return gradient;
}

double NegativeEntropyObjective::Evaluate(
    const Eigen::MatrixXd& z, const Eigen::MatrixXd& /*mean*/,
    const Eigen::MatrixXd& variance,
    const std::vector<Eigen::MatrixXd>* /*mean_jacobians*/,
    const std::vector<Eigen::MatrixXd>* variance_jacobians,
    Eigen::MatrixXd* gradient) const {
  if (gradient != nullptr) {
    gradient->setZero(z.rows(), z.cols());
    for (Eigen::Index i = 0; i < z.rows(); ++i) {
      gradient->row(i) = -EntropyGradient(variance.row(i).transpose(),
                                          (*variance_jacobians)[static_cast<size_t>(i)])
                              .transpose();
    }
  }
  return -Entropy(variance);
}

}  // namespace excite::plan
