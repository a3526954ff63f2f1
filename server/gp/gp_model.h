#ifndef EXCITE_SERVER_GP_GP_MODEL_H_
#define EXCITE_SERVER_GP_GP_MODEL_H_

#include <Eigen/Dense>
#include <vector>

#include "absl/status/status.h"
#include "server/gp/hyperparameters.h"

namespace excite::gp {

// One exact GP with a squared-exponential ARD kernel (see hyperparameters.h) and
// zero prior mean, on data that the caller has already normalised. Caches the
// Cholesky factor L of K = K_f + (noise_variance + jitter) I, alpha = K^-1 y and
// log|K|.
//
// Ill-conditioning: if the Cholesky factorisation fails (or yields non-finite
// numbers), a jitter of 1e-10 * signal_variance, growing tenfold up to
// 1e-2 * signal_variance, is added to the diagonal and the factorisation retried;
// jitter() reports what was used (0 normally).
//
// Not thread-safe for mutation; const methods may run concurrently.
class GpModel {
 public:
  GpModel() = default;

  // Replaces data and hyperparameters; x: n x d (one point per row), y: n.
  // O(n^3). INVALID_ARGUMENT on inconsistent shapes or invalid hyperparameters
  // (non-positive or non-finite), INTERNAL if even the largest jitter fails (the
  // model is then left empty; cannot happen for finite data and hyperparameters).
  absl::Status Reset(Eigen::MatrixXd x, Eigen::VectorXd y,
                     const Hyperparameters& hyperparameters);

  // New hyperparameters on the same data: refactorises, O(n^3).
  absl::Status SetHyperparameters(const Hyperparameters& hyperparameters);

  // New targets (n entries) on the same inputs and hyperparameters: two
  // triangular solves with the cached factor, O(n^2). INVALID_ARGUMENT on a wrong
  // size or non-finite values (nothing changes then).
  absl::Status SetTargets(Eigen::VectorXd y);

  // Appends one sample (x: d entries) as a row append to L, O(n^2); falls back to
  // a full refactorisation (with jitter) only if the new pivot is not positive.
  absl::Status AddSample(const Eigen::VectorXd& x, double y);

  int size() const { return n_; }
  int dim() const { return static_cast<int>(hyperparameters_.lengthscales.size()); }
  const Hyperparameters& hyperparameters() const { return hyperparameters_; }
  const Eigen::MatrixXd& inputs() const { return x_; }
  const Eigen::VectorXd& targets() const { return y_; }
  // Jitter added to the diagonal in the current factorisation (0 if none).
  double jitter() const { return jitter_; }

  // Lower Cholesky factor of K (n x n copy), alpha = K^-1 y, log|K|.
  Eigen::MatrixXd cholesky() const;
  const Eigen::VectorXd& alpha() const { return alpha_; }
  double log_det() const { return log_det_; }

  // log p(y | X, theta) = -y^T alpha / 2 - log|K| / 2 - n log(2 pi) / 2. O(1).
  double log_marginal_likelihood() const;

  // Gradient of the LML w.r.t. theta = (log signal_variance, log lengthscale_1..d,
  // log noise_variance) (d + 2 entries). With W = alpha alpha^T - K^-1 and
  // A = W o K_f: the signal part is sum(A)/2, the lengthscale part one product
  // A * S (kernel.h), the noise part noise_variance * tr(W) / 2. O(n^3) (K^-1).
  Eigen::VectorXd LogMarginalLikelihoodGradient() const;

  // For m points xs (m x d): latent posterior mean and variance (m each; the
  // variance is clamped at 0). If not null, Jacobians w.r.t. xs, m x d each
  // (row i = gradient at point i): one pass with V = L \ K*^T and
  // w = L^T \ V. O(m n^2 + m n d). Requires size() > 0.
  void Predict(const Eigen::MatrixXd& xs, Eigen::VectorXd* mean,
               Eigen::VectorXd* variance, Eigen::MatrixXd* mean_jacobian,
               Eigen::MatrixXd* variance_jacobian) const;

  // Joint posterior covariances, for information objectives over many points.
  // CrossFactor(xs) = L \ K(X, xs) (n x m): what depends on the data and on a
  // point set, computed once per set, O(m n^2). Requires size() > 0.
  Eigen::MatrixXd CrossFactor(const Eigen::MatrixXd& xs) const;
  // Latent posterior covariance k_D(a, b) = k(a, b) - V_a^T V_b (rows(a) x rows(b))
  // from the points and their CrossFactor. O(m_a m_b (n + d)).
  Eigen::MatrixXd PosteriorCovariance(const Eigen::MatrixXd& a,
                                      const Eigen::MatrixXd& a_factor,
                                      const Eigen::MatrixXd& b,
                                      const Eigen::MatrixXd& b_factor) const;
  // Gradient w.r.t. the points a (every b held fixed) of
  // sum_t sum_ik w_t(i, k) k_D(a_i, b_t,k): rows(a) x d, row i = d / d a_i; each
  // w_t is rows(a) x rows(b_t). For a symmetric weight on k_D(a, a), pass b = a
  // and 2 w (k_D is symmetric). One triangular solve for all terms:
  // O(m_a n^2 + sum_t m_a m_b n).
  struct CovarianceTerm {
    const Eigen::MatrixXd* b;         // m_b x d
    const Eigen::MatrixXd* b_factor;  // CrossFactor(b)
    const Eigen::MatrixXd* w;         // m_a x m_b
  };
  Eigen::MatrixXd PosteriorCovarianceGradient(
      const Eigen::MatrixXd& a, const std::vector<CovarianceTerm>& terms) const;

 private:
  absl::Status Factorise();
  // Views of L and L^T (n x n).
  auto LowerFactor() const {
    return l_.topLeftCorner(n_, n_).triangularView<Eigen::Lower>();
  }
  auto UpperFactor() const {
    return l_.topLeftCorner(n_, n_).transpose().triangularView<Eigen::Upper>();
  }

  int n_ = 0;
  Hyperparameters hyperparameters_;
  Eigen::MatrixXd x_;         // n x d
  Eigen::MatrixXd x_scaled_;  // x / lengthscales
  Eigen::VectorXd y_;
  Eigen::MatrixXd kf_;     // noise-free K of the last factorisation (empty if stale)
  Eigen::MatrixXd l_;      // capacity x capacity; top-left n x n lower triangle is L
  Eigen::VectorXd beta_;   // L^-1 y
  Eigen::VectorXd alpha_;  // K^-1 y
  double log_det_ = 0.0;
  double jitter_ = 0.0;
};

}  // namespace excite::gp

#endif  // EXCITE_SERVER_GP_GP_MODEL_H_
