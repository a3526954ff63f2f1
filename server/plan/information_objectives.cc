#include "server/plan/information_objectives.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"

namespace excite::plan {
namespace {

absl::StatusOr<Eigen::VectorXd> CheckedNoise(const gp::DynamicsPredictor& model) {
  // A model without joint covariances returns no prepared set.
  if (model.PreparePoints(Eigen::MatrixXd::Zero(1, model.z_dim())) == nullptr) {
    return absl::InvalidArgumentError(
        "this strategy needs a model with joint posterior covariances");
  }
  Eigen::VectorXd noise = model.ObservationNoiseVariances();
  if (noise.size() != model.state_dim() || !noise.allFinite() ||
      !(noise.array() > 0.0).all()) {
    return absl::InvalidArgumentError(
        "this strategy needs a model with positive observation noise variances");
  }
  return noise;
}

// B = K + noise I (M x M), factorised; false if not positive definite (a
// non-finite covariance: the caller reports a non-finite objective).
bool FactoriseNoisy(const Eigen::MatrixXd& cov, double noise,
                    Eigen::LLT<Eigen::MatrixXd>* llt) {
  Eigen::MatrixXd b = cov;
  b.diagonal().array() += noise;
  llt->compute(b);
  return llt->info() == Eigen::Success;
}

double LogDet(const Eigen::LLT<Eigen::MatrixXd>& llt) {
  return 2.0 * llt.matrixLLT().diagonal().array().log().sum();
}

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

}  // namespace

absl::StatusOr<std::unique_ptr<NegativeMutualInformationObjective>>
NegativeMutualInformationObjective::Create(const gp::DynamicsPredictor& model) {
  absl::StatusOr<Eigen::VectorXd> noise = CheckedNoise(model);
  if (!noise.ok()) return noise.status();
  return std::unique_ptr<NegativeMutualInformationObjective>(
      new NegativeMutualInformationObjective(model, *std::move(noise)));
}

NegativeMutualInformationObjective::NegativeMutualInformationObjective(
    const gp::DynamicsPredictor& model, Eigen::VectorXd noise)
    : model_(model), noise_(std::move(noise)) {}

double NegativeMutualInformationObjective::Evaluate(
    const Eigen::MatrixXd& z, const Eigen::MatrixXd& /*mean*/,
    const Eigen::MatrixXd& /*variance*/,
    const std::vector<Eigen::MatrixXd>* /*mean_jacobians*/,
    const std::vector<Eigen::MatrixXd>* /*variance_jacobians*/,
    Eigen::MatrixXd* gradient) const {
  const std::unique_ptr<gp::DynamicsPredictor::PreparedPoints> points =
      model_.PreparePoints(z);
  const std::vector<Eigen::MatrixXd> cov = model_.PosteriorCovariance(*points, *points);
  const Eigen::Index m = z.rows();
  double value = 0.0;
  std::vector<Eigen::MatrixXd> weights;
  for (int j = 0; j < model_.state_dim(); ++j) {
    Eigen::LLT<Eigen::MatrixXd> llt;
    if (!FactoriseNoisy(cov[j], noise_(j), &llt)) {
      if (gradient != nullptr) gradient->setConstant(m, z.cols(), kNaN);
      return kNaN;
    }
    // 1/2 log det(I + K / s) = 1/2 (log det(K + s I) - M log s).
    value -= 0.5 * (LogDet(llt) - static_cast<double>(m) * std::log(noise_(j)));
    // dJ/dK = -1/2 B^-1; K(Z, Z) depends on Z in both arguments: weight 2 dJ/dK.
    if (gradient != nullptr) {
      weights.push_back(-llt.solve(Eigen::MatrixXd::Identity(m, m)));
    }
  }
  if (gradient != nullptr) {
    *gradient = model_.PosteriorCovarianceGradient(*points, {{points.get(), &weights}});
  }
  return value;
}

absl::StatusOr<std::unique_ptr<NegativeVarianceReductionObjective>>
NegativeVarianceReductionObjective::Create(const gp::DynamicsPredictor& model,
                                           const Eigen::MatrixXd& reference) {
  absl::StatusOr<Eigen::VectorXd> noise = CheckedNoise(model);
  if (!noise.ok()) return noise.status();
  if (reference.rows() < 1 || reference.cols() != model.z_dim() ||
      !reference.allFinite()) {
    return absl::InvalidArgumentError(
        absl::StrCat("the reference set must be N >= 1 finite points of z_dim (",
                     model.z_dim(), ") entries"));
  }
  std::unique_ptr<gp::DynamicsPredictor::PreparedPoints> prepared =
      model.PreparePoints(reference);
  const double total = model.PosteriorVariance(*prepared).sum();
  if (!std::isfinite(total)) {
    return absl::InvalidArgumentError(
        "the model's variance over the reference set is not finite");
  }
  return std::unique_ptr<NegativeVarianceReductionObjective>(
      new NegativeVarianceReductionObjective(
          model, *std::move(noise), std::move(prepared), std::max(total, 1e-300)));
}

NegativeVarianceReductionObjective::NegativeVarianceReductionObjective(
    const gp::DynamicsPredictor& model, Eigen::VectorXd noise,
    std::unique_ptr<gp::DynamicsPredictor::PreparedPoints> reference,
    double total_variance)
    : model_(model),
      noise_(std::move(noise)),
      reference_(std::move(reference)),
      total_variance_(total_variance) {}

double NegativeVarianceReductionObjective::Evaluate(
    const Eigen::MatrixXd& z, const Eigen::MatrixXd& /*mean*/,
    const Eigen::MatrixXd& /*variance*/,
    const std::vector<Eigen::MatrixXd>* /*mean_jacobians*/,
    const std::vector<Eigen::MatrixXd>* /*variance_jacobians*/,
    Eigen::MatrixXd* gradient) const {
  const std::unique_ptr<gp::DynamicsPredictor::PreparedPoints> points =
      model_.PreparePoints(z);
  const std::vector<Eigen::MatrixXd> zz = model_.PosteriorCovariance(*points, *points);
  const std::vector<Eigen::MatrixXd> zr =
      model_.PosteriorCovariance(*points, *reference_);
  const double scale = 1.0 / total_variance_;
  double value = 0.0;
  std::vector<Eigen::MatrixXd> zr_weights, zz_weights;
  for (int j = 0; j < model_.state_dim(); ++j) {
    Eigen::LLT<Eigen::MatrixXd> llt;
    if (!FactoriseNoisy(zz[j], noise_(j), &llt)) {
      if (gradient != nullptr) gradient->setConstant(z.rows(), z.cols(), kNaN);
      return kNaN;
    }
    const Eigen::MatrixXd a = llt.solve(zr[j]);  // B^-1 C, M x N
    value -= scale * zr[j].cwiseProduct(a).sum();
    if (gradient != nullptr) {
      // J = -tr(C^T B^-1 C) / V: dJ/dC = -2 A / V, dJ/dB = A A^T / V (symmetric,
      // and B = K(Z, Z) + s I depends on Z in both arguments: weight twice that).
      zr_weights.push_back(-2.0 * scale * a);
      zz_weights.push_back(2.0 * scale * a * a.transpose());
    }
  }
  if (gradient != nullptr) {
    *gradient = model_.PosteriorCovarianceGradient(
        *points, {{reference_.get(), &zr_weights}, {points.get(), &zz_weights}});
  }
  return value;
}

}  // namespace excite::plan
