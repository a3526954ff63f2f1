#include "server/gp/kernel.h"

#include <Eigen/Dense>

namespace excite::gp {

Eigen::MatrixXd ScaleInputs(const Eigen::MatrixXd& x,
                            const Eigen::VectorXd& lengthscales) {
  return x * lengthscales.cwiseInverse().asDiagonal();
}

Eigen::MatrixXd CrossCovariance(const Eigen::MatrixXd& a_scaled,
                                const Eigen::MatrixXd& b_scaled, double signal_variance) {
  // |a - b|^2 = |a|^2 + |b|^2 - 2 a.b, clamped at 0 against cancellation; the
  // norms and the exp in one pass per column (large batches are memory-bound).
  Eigen::MatrixXd k = -2.0 * a_scaled * b_scaled.transpose();
  const Eigen::VectorXd a_norms = a_scaled.rowwise().squaredNorm();
  const Eigen::VectorXd b_norms = b_scaled.rowwise().squaredNorm();
  for (Eigen::Index j = 0; j < k.cols(); ++j) {
    auto column = k.col(j);
    column += a_norms;
    column.array() += b_norms(j);
    column = signal_variance * (-0.5 * column.cwiseMax(0.0)).array().exp().matrix();
  }
  return k;
}

Eigen::MatrixXd Covariance(const Eigen::MatrixXd& s_scaled, double signal_variance) {
  const Eigen::Index n = s_scaled.rows();
  // Eigen's rank update binds a reference to an empty matrix's null data (UBSan).
  if (n == 0) return Eigen::MatrixXd(0, 0);
  Eigen::MatrixXd d2 = Eigen::MatrixXd::Zero(n, n);
  d2.selfadjointView<Eigen::Lower>().rankUpdate(s_scaled, -2.0);  // -2 s_i . s_j
  // The lower triangle only (exp is most of the cost), mirrored so that the
  // result is exactly symmetric.
  const Eigen::VectorXd norms = s_scaled.rowwise().squaredNorm();
  Eigen::MatrixXd& k = d2;
  for (Eigen::Index j = 0; j < n; ++j) {
    auto column = k.col(j).tail(n - j);
    column += norms.tail(n - j);
    column.array() += norms(j);
    column(0) = 0.0;
    column = signal_variance * (-0.5 * column.cwiseMax(0.0)).array().exp().matrix();
  }
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
