#ifndef EXCITE_SERVER_PLAN_INFORMATION_OBJECTIVES_H_
#define EXCITE_SERVER_PLAN_INFORMATION_OBJECTIVES_H_

#include <Eigen/Dense>
#include <memory>
#include <vector>

#include "absl/status/statusor.h"
#include "server/gp/dynamics_predictor.h"
#include "server/plan/shooting_objective.h"

namespace excite::plan {

// Objectives that value the M points of a horizon *jointly*, through the model's
// posterior covariances (DynamicsPredictor::PreparePoints and friends): a horizon
// that visits one uncertain place twice is not paid twice. Both read the model
// at construction (noise variances, prepared reference points), so the model must
// not change while they live. Gradients are exact (checked against finite
// differences and Ipopt's derivative checker in tests/plan).

// mi: minus the mutual information between the horizon's latent values and their
// noisy observations, summed over outputs j (nats):
//   J = -sum_j 1/2 log det(I + K_j(Z, Z) / noise_j),
// K_j the posterior covariance given the data, noise_j the observation noise.
// Per evaluation O(M n^2) per output (plus O(M^3)).
class NegativeMutualInformationObjective final : public ShootingObjective {
 public:
  // INVALID_ARGUMENT if the model has no joint covariances or noise variances.
  static absl::StatusOr<std::unique_ptr<NegativeMutualInformationObjective>> Create(
      const gp::DynamicsPredictor& model);

  double Evaluate(const Eigen::MatrixXd& z, const Eigen::MatrixXd& mean,
                  const Eigen::MatrixXd& variance,
                  const std::vector<Eigen::MatrixXd>* mean_jacobians,
                  const std::vector<Eigen::MatrixXd>* variance_jacobians,
                  Eigen::MatrixXd* gradient) const override;

 private:
  NegativeMutualInformationObjective(const gp::DynamicsPredictor& model,
                                     Eigen::VectorXd noise);
  const gp::DynamicsPredictor& model_;
  Eigen::VectorXd noise_;
};

// roi: minus the expected reduction of the posterior variance over a fixed
// reference set R of N points (typically spread over region of interest x input
// bounds) if the horizon's points Z were observed with the observation noise,
// summed over outputs and divided by the current total variance over R:
//   J = -sum_j tr(K_j(R, Z) (K_j(Z, Z) + noise_j I)^-1 K_j(Z, R)) / V,
//   V = sum_j sum_r var_j(r),
// so -J is the fraction of today's uncertainty over R that the horizon removes
// (in [0, 1]). It targets what an RMSE over R measures. L \ K(X, R) is computed
// once at construction (O(N n^2)); each evaluation costs O(M n^2 + N M n) per
// output.
class NegativeVarianceReductionObjective final : public ShootingObjective {
 public:
  // reference: N x z_dim (N >= 1). INVALID_ARGUMENT if the model has no joint
  // covariances or noise variances, or on a wrong shape.
  static absl::StatusOr<std::unique_ptr<NegativeVarianceReductionObjective>> Create(
      const gp::DynamicsPredictor& model, const Eigen::MatrixXd& reference);

  double Evaluate(const Eigen::MatrixXd& z, const Eigen::MatrixXd& mean,
                  const Eigen::MatrixXd& variance,
                  const std::vector<Eigen::MatrixXd>* mean_jacobians,
                  const std::vector<Eigen::MatrixXd>* variance_jacobians,
                  Eigen::MatrixXd* gradient) const override;

  // V: the summed posterior variance over the reference set today.
  double total_variance() const { return total_variance_; }

 private:
  NegativeVarianceReductionObjective(
      const gp::DynamicsPredictor& model, Eigen::VectorXd noise,
      std::unique_ptr<gp::DynamicsPredictor::PreparedPoints> reference,
      double total_variance);
  const gp::DynamicsPredictor& model_;
  Eigen::VectorXd noise_;
  std::unique_ptr<gp::DynamicsPredictor::PreparedPoints> reference_;
  double total_variance_;
};

}  // namespace excite::plan

#endif  // EXCITE_SERVER_PLAN_INFORMATION_OBJECTIVES_H_
