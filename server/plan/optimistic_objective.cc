#include "server/plan/optimistic_objective.h"

#include <cmath>
#include <utility>

#include "absl/strings/str_cat.h"
#include "server/plan/entropy_objective.h"

namespace excite::plan {

absl::StatusOr<NegativeLogVarianceRatioObjective>
NegativeLogVarianceRatioObjective::Create(Eigen::VectorXd noise) {
  if (noise.size() == 0 || !noise.allFinite() || !(noise.array() > 0.0).all()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "the optimistic objective needs finite positive noise variances, got ",
        noise.size(), " values"));
  }
  return NegativeLogVarianceRatioObjective(std::move(noise));
}

double NegativeLogVarianceRatioObjective::Evaluate(
    const Eigen::MatrixXd& z, const Eigen::MatrixXd& /*mean*/,
    const Eigen::MatrixXd& variance,
    const std::vector<Eigen::MatrixXd>* /*mean_jacobians*/,
    const std::vector<Eigen::MatrixXd>* variance_jacobians,
    Eigen::MatrixXd* gradient) const {
  if (gradient != nullptr) gradient->setZero(z.rows(), z.cols());
  double value = 0.0;
  for (Eigen::Index i = 0; i < variance.rows(); ++i) {
    for (Eigen::Index j = 0; j < variance.cols(); ++j) {
      const double v = variance(i, j);
      const bool floored = !(v >= kVarianceFloor);  // also catches NaN
      const double used = floored ? kVarianceFloor : v;
      value -= std::log1p(used / noise_(j));
      if (gradient != nullptr && !floored) {
        gradient->row(i) -= (1.0 / (noise_(j) + used)) *
                            (*variance_jacobians)[static_cast<size_t>(i)].row(j);
      }
    }
  }
  return value;
}

}  // namespace excite::plan
