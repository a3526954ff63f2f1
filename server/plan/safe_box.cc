#include "server/plan/safe_box.h"

#include <algorithm>
#include <cmath>

#include "server/plan/entropy_objective.h"

namespace excite::plan {

double SafeBoxViolation(const SafeBox& box, const Eigen::MatrixXd& mean,
                        const Eigen::MatrixXd& variance) {
  if (!box.active()) return 0.0;
  // The same floor as the NLP's constraint rows.
  const Eigen::ArrayXXd sd = variance.array().max(kVarianceFloor).sqrt();
  const Eigen::ArrayXXd high = mean.array() + box.margin * sd -
                               box.upper.transpose().replicate(mean.rows(), 1).array();
  const Eigen::ArrayXXd low = box.lower.transpose().replicate(mean.rows(), 1).array() -
                              (mean.array() - box.margin * sd);
  const double violation = std::max({0.0, high.maxCoeff(), low.maxCoeff()});
  return violation <= kSafeBoxTolerance ? 0.0 : violation;
}

}  // namespace excite::plan
