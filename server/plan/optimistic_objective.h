#ifndef EXCITE_SERVER_PLAN_OPTIMISTIC_OBJECTIVE_H_
#define EXCITE_SERVER_PLAN_OPTIMISTIC_OBJECTIVE_H_

#include <Eigen/Dense>
#include <vector>

#include "absl/status/statusor.h"
#include "server/plan/shooting_objective.h"

namespace excite::plan {

// The objective of optimistic exploration (OPAX, Sukhija et al., NeurIPS 2023):
// minus the summed information gain of single observations along the horizon,
//   J = -sum_i sum_j log(1 + var_j(z_i) / noise_j),
// where noise_j is output j's observation noise variance. Evaluated on the
// hallucinated (optimistic) trajectory that MultipleShootingNlp::SetOptimism
// makes the NLP follow. Variances below kVarianceFloor count as the floor
// (gradient 0 there). Immutable after Create; thread-compatible.
class NegativeLogVarianceRatioObjective final : public ShootingObjective {
 public:
  // noise: state_dim observation noise variances, finite and > 0; otherwise
  // INVALID_ARGUMENT.
  static absl::StatusOr<NegativeLogVarianceRatioObjective> Create(Eigen::VectorXd noise);

  double Evaluate(const Eigen::MatrixXd& z, const Eigen::MatrixXd& mean,
                  const Eigen::MatrixXd& variance,
                  const std::vector<Eigen::MatrixXd>* mean_jacobians,
                  const std::vector<Eigen::MatrixXd>* variance_jacobians,
                  Eigen::MatrixXd* gradient) const override;

 private:
  explicit NegativeLogVarianceRatioObjective(Eigen::VectorXd noise)
      : noise_(std::move(noise)) {}
  Eigen::VectorXd noise_;
};

}  // namespace excite::plan

#endif  // EXCITE_SERVER_PLAN_OPTIMISTIC_OBJECTIVE_H_
