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

}  // namespace excite::plan
