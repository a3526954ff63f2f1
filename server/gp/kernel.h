#ifndef EXCITE_SERVER_GP_KERNEL_H_
#define EXCITE_SERVER_GP_KERNEL_H_

#include <Eigen/Dense>

namespace excite::gp {

// Squared-exponential ARD kernel
//   k(a, b) = signal_variance * exp(-0.5 * sum_l ((a_l - b_l) / lengthscale_l)^2).
// The functions below work on *scaled* inputs s = x / lengthscales (one point per
// row), so a kernel matrix costs one matrix product plus an exp per entry.

// Returns x with column l divided by lengthscales(l). x: n x d, lengthscales: d.
Eigen::MatrixXd ScaleInputs(const Eigen::MatrixXd& x,
                            const Eigen::VectorXd& lengthscales);

// Cross-covariance K(a, b) (rows of a x rows of b) from scaled inputs. O(n m d).
Eigen::MatrixXd CrossCovariance(const Eigen::MatrixXd& a_scaled,
                                const Eigen::MatrixXd& b_scaled, double signal_variance);

// Symmetric covariance K(s, s) without noise; the diagonal is exactly
// signal_variance and the result is exactly symmetric. O(n^2 d).
Eigen::MatrixXd Covariance(const Eigen::MatrixXd& s_scaled, double signal_variance);

// Given a symmetric n x n matrix `a` (in the LML gradient: A = W o K with
// W = alpha alpha^T - K^-1 and K the noise-free kernel matrix) and the scaled
// inputs s (n x d), returns for every dimension l
//   0.5 * sum_ij a_ij (s_il - s_jl)^2,
// i.e. 0.5 tr(W dK/dlog(lengthscale_l)). One n x n by n x d product: O(n^2 d).
Eigen::VectorXd LogLengthscaleGradient(const Eigen::MatrixXd& a,
                                       const Eigen::MatrixXd& s_scaled);

}  // namespace excite::gp

#endif  // EXCITE_SERVER_GP_KERNEL_H_
