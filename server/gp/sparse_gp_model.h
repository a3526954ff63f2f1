#ifndef EXCITE_SERVER_GP_SPARSE_GP_MODEL_H_
#define EXCITE_SERVER_GP_SPARSE_GP_MODEL_H_

#include <Eigen/Dense>
#include <cstdint>

#include "absl/status/status.h"
#include "server/gp/hyperparameters.h"

namespace excite::gp {

struct SparseGpOptions {
  // Most inducing points kept (the model's size and a prediction's cost).
  int max_inducing = 256;
  // A sample becomes an inducing point when the part of its prior variance that
  // the inducing points do not explain, k(x, x) - Q(x, x), exceeds this fraction
  // of the noise variance (and there is room). Relative to the noise because the
  // approximation's error is: the variational bound's gap is
  // sum_i (k(x_i, x_i) - Q(x_i, x_i)) / (2 noise variance).
  double inducing_tolerance = 0.1;
};

// A sparse GP with inducing points: the deterministic training conditional (DTC;
// its predictions are those of the variational sparse GP of Titsias 2009) with a
// squared-exponential ARD kernel and zero prior mean, on data the caller has
// already normalised. Inducing points Z are samples, chosen online: a sample is
// added to Z when Z explains its prior variance badly (see SparseGpOptions), so
// the model covers each region it has data in, and Reset() on a batch picks the
// same Z as adding the batch one sample at a time.
//
// With Kzz = L L^T, A = L^-1 K(Z, X) / sigma_n and B = I + A A^T = L_B L_B^T:
//   mean(x) = k(x, Z) L^-T L_B^-T L_B^-1 A y / sigma_n,
//   var(x)  = k(x, x) - |L^-1 k(Z, x)|^2 + |L_B^-1 L^-1 k(Z, x)|^2.
// With Z = X this is the exact GP. Only L, L_B and M-vectors are kept besides
// the data, so a sample costs O(M^2) (a rank-one update of L_B), an inducing
// point O(n M d) (one pass over the data), a prediction O(M^2) per point:
// none of it grows with n but the inducing point's pass.
//
// Not thread-safe for mutation; const methods may run concurrently.
class SparseGpModel {
 public:
  explicit SparseGpModel(SparseGpOptions options = {});

  // Replaces data and hyperparameters and chooses the inducing points; x: n x d
  // (one point per row), y: n. O(n M^2 + n M d). INVALID_ARGUMENT on inconsistent
  // shapes, non-finite data, invalid hyperparameters or options.
  absl::Status Reset(Eigen::MatrixXd x, Eigen::VectorXd y,
                     const Hyperparameters& hyperparameters);

  // Appends one sample (x: d entries), first as an inducing point if it
  // qualifies. O(M^2), or O(n M d) when it becomes an inducing point.
  absl::Status AddSample(const Eigen::VectorXd& x, double y);

  // Subtracts `delta` from every target (a new prior mean): O(M^2).
  void ShiftTargets(double delta);

  int size() const { return static_cast<int>(y_.size()); }
  int inducing_count() const { return m_; }
  int dim() const { return static_cast<int>(hyperparameters_.lengthscales.size()); }
  const Hyperparameters& hyperparameters() const { return hyperparameters_; }
  const SparseGpOptions& options() const { return options_; }
  const Eigen::MatrixXd& inputs() const { return x_; }
  const Eigen::VectorXd& targets() const { return y_; }
  // Row indices into inputs() of the inducing points, in the order chosen.
  Eigen::VectorXi inducing_indices() const { return inducing_.head(m_); }
  // What Predict uses (see above): mean(x) = k(x, Z) weights(); the lower
  // factors L = chol(Kzz) and L_B = chol(B) (m x m copies).
  const Eigen::VectorXd& weights() const { return weights_; }
  Eigen::MatrixXd kernel_factor() const;
  Eigen::MatrixXd b_factor() const;

  // As GpModel::Predict: for m points xs (m x d), latent posterior mean and
  // variance (clamped at 0) and, if not null, their Jacobians w.r.t. xs (m x d,
  // row i = gradient at point i). O(m M^2 + m M d). Requires size() > 0.
  void Predict(const Eigen::MatrixXd& xs, Eigen::VectorXd* mean,
               Eigen::VectorXd* variance, Eigen::MatrixXd* mean_jacobian,
               Eigen::MatrixXd* variance_jacobian) const;

  // Bytes of what the model keeps besides its data (n (d + 1) doubles twice:
  // raw and scaled inputs), for `max_inducing` points of dimension d.
  static int64_t FactorBytes(int max_inducing, int dim);
  // Bytes Reset() and an inducing point's addition allocate while they run (blocks
  // of the m x n matrix A and B = I + A A^T).
  static int64_t WorkspaceBytes(int max_inducing);

 private:
  absl::Status CheckSample(const Eigen::VectorXd& x, double y) const;
  // Adds scaled point s (a row of x_scaled_ at `index`, not yet in the data
  // products) to Z if it qualifies.
  void MaybeAddInducing(int index);
  // Adds the data point at `index` of x_scaled_ to A y, A 1 and B.
  void AddToProducts(int index);
  // c = L_B^-1 A y / sigma_n, weights = L^-T L_B^-T c.
  void UpdateWeights();

  SparseGpOptions options_;
  Hyperparameters hyperparameters_;
  Eigen::MatrixXd x_;         // n x d
  Eigen::MatrixXd x_scaled_;  // x / lengthscales
  Eigen::VectorXd y_;
  int m_ = 0;                 // inducing points
  Eigen::VectorXi inducing_;  // m: rows of x_
  Eigen::MatrixXd z_scaled_;  // capacity x d: the first m rows are Z / lengthscales
  Eigen::MatrixXd l_;         // capacity^2: lower m x m is chol(Kzz)
  Eigen::MatrixXd lb_;        // capacity^2: lower m x m is chol(B)
  Eigen::VectorXd ay_;        // A y / sigma_n (m)
  Eigen::VectorXd a1_;        // A 1 / sigma_n (m), for ShiftTargets
  Eigen::VectorXd weights_;   // mean(x) = k(x, Z) weights (m)
};

}  // namespace excite::gp

#endif  // EXCITE_SERVER_GP_SPARSE_GP_MODEL_H_
