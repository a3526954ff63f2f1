#include "server/gp/kernel.h"

#include <Eigen/Dense>

namespace excite::gp {

Eigen::MatrixXd ScaleInputs(const Eigen::MatrixXd& x,
                            const Eigen::VectorXd& lengthscales) {
  return x * lengthscales.cwiseInverse().asDiagonal();
}

Eigen::MatrixXd CrossCovariance(const Eigen::MatrixXd& a_scaled,
                                const Eigen::MatrixXd& b_scaled, double signal_variance) {
  // |a - b|^2 = |a|^2 + |b|^2 - 2 a.b; clamped at 0 against cancellation.
  Eigen::MatrixXd d2 = -2.0 * a_scaled * b_scaled.transpose();
  d2.colwise() += a_scaled.rowwise().squaredNorm();
  d2.rowwise() += b_scaled.rowwise().squaredNorm().transpose();
  return signal_variance * (-0.5 * d2.cwiseMax(0.0)).array().exp().matrix();
}

Eigen::MatrixXd Covariance(const Eigen::MatrixXd& s_scaled, double signal_variance) {
  const Eigen::Index n = s_scaled.rows();
  // Eigen's rank update binds a reference to an empty matrix's null data (UBSan).
  if (n == 0) return Eigen::MatrixXd(0, 0);
  Eigen::MatrixXd d2 = Eigen::MatrixXd::Zero(n, n);
  d2.selfadjointView<Eigen::Lower>().rankUpdate(s_scaled, -2.0);
  d2.colwise() += s_scaled.rowwise().squaredNorm();
  d2.rowwise() += s_scaled.rowwise().squaredNorm().transpose();
  d2.diagonal().setZero();
  // Only the lower triangle is meaningful; exp is applied to the whole (vectorised)
  // and the lower triangle mirrored so the result is exactly symmetric.
  Eigen::MatrixXd k = signal_variance * (-0.5 * d2.cwiseMax(0.0)).array().exp().matrix();
  for (Eigen::Index j = 1; j < n; ++j) {
    k.col(j).head(j) = k.row(j).head(j).transpose();
  }
  return k;
}

Eigen::VectorXd LogLengthscaleGradient(const Eigen::MatrixXd& a,
                                       const Eigen::MatrixXd& s_scaled) {
  // sum_ij a_ij (s_il - s_jl)^2 = 2 sum_i s_il^2 r_i - 2 sum_i s_il (a s)_il
  // with r the row sums of a (a symmetric).
  const Eigen::VectorXd r = a.rowwise().sum();
  const Eigen::MatrixXd as = a * s_scaled;
  return s_scaled.cwiseAbs2().transpose() * r -
         s_scaled.cwiseProduct(as).colwise().sum().transpose();
}

}  // namespace excite::gp
