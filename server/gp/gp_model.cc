#include "server/gp/gp_model.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <utility>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "server/gp/dense_linear_algebra.h"
#include "server/gp/kernel.h"

namespace excite::gp {
namespace {

constexpr double kLog2Pi = 1.8378770664093454835606594728112;

bool Valid(double v) { return std::isfinite(v) && v > 0.0; }

absl::Status CheckHyperparameters(const Hyperparameters& h, Eigen::Index dim) {
  if (h.lengthscales.size() != dim) {
    return absl::InvalidArgumentError(
        absl::StrCat("expected ", dim, " lengthscales, got ", h.lengthscales.size()));
  }
  if (!Valid(h.signal_variance) || !Valid(h.noise_variance)) {
    return absl::InvalidArgumentError("variances must be finite and positive");
  }
  for (Eigen::Index i = 0; i < dim; ++i) {
    if (!Valid(h.lengthscales(i))) {
      return absl::InvalidArgumentError("lengthscales must be finite and positive");
    }
  }
  return absl::OkStatus();
}

}  // namespace

absl::Status GpModel::Reset(Eigen::MatrixXd x, Eigen::VectorXd y,
                            const Hyperparameters& hyperparameters) {
  if (x.rows() != y.size()) {
    return absl::InvalidArgumentError(
        absl::StrCat("x has ", x.rows(), " rows but y has ", y.size(), " entries"));
  }
  if (absl::Status s = CheckHyperparameters(hyperparameters, x.cols()); !s.ok()) return s;
  if (!x.allFinite() || !y.allFinite()) {
    return absl::InvalidArgumentError("non-finite data");
  }
  hyperparameters_ = hyperparameters;
  x_ = std::move(x);
  y_ = std::move(y);
  n_ = static_cast<int>(y_.size());
  x_scaled_ = ScaleInputs(x_, hyperparameters_.lengthscales);
  return Factorise();
}

absl::Status GpModel::SetHyperparameters(const Hyperparameters& hyperparameters) {
  if (absl::Status s = CheckHyperparameters(hyperparameters, x_.cols()); !s.ok())
    return s;
  hyperparameters_ = hyperparameters;
  x_scaled_ = ScaleInputs(x_, hyperparameters_.lengthscales);
  return Factorise();
}

absl::Status GpModel::SetTargets(Eigen::VectorXd y) {
  if (y.size() != n_) {
    return absl::InvalidArgumentError(
        absl::StrCat("expected ", n_, " targets, got ", y.size()));
  }
  if (!y.allFinite()) return absl::InvalidArgumentError("non-finite targets");
  y_ = std::move(y);
  if (n_ == 0) return absl::OkStatus();
  beta_ = LowerFactor().solve(y_);
  alpha_ = UpperFactor().solve(beta_);
  return absl::OkStatus();
}

absl::Status GpModel::Factorise() {
  const int n = n_;
  if (l_.rows() < n) {
    const Eigen::Index capacity = std::max<Eigen::Index>(16, n + n / 4 + 8);
    l_.resize(capacity, capacity);
  }
  const double sf2 = hyperparameters_.signal_variance;
  const double sn2 = hyperparameters_.noise_variance;
  kf_ = Covariance(x_scaled_, sf2);
  const Eigen::MatrixXd& k = kf_;
  double jitter = 0.0;
  for (int attempt = 0; attempt < 10; ++attempt) {
    auto block = l_.topLeftCorner(n, n);
    block.triangularView<Eigen::Lower>() = k;
    block.diagonal().array() += sn2 + jitter;
    bool ok = CholeskyInPlace(block);
    if (ok) {
      const auto diag = block.diagonal();
      ok = diag.allFinite() && (diag.array() > 0.0).all();
    }
    if (ok) {
      beta_ = LowerFactor().solve(y_);
      alpha_ = UpperFactor().solve(beta_);
      ok = beta_.allFinite() && alpha_.allFinite();
    }
    if (ok) {
      log_det_ = 2.0 * block.diagonal().array().log().sum();
      jitter_ = jitter;
      return absl::OkStatus();
    }
    jitter = jitter == 0.0 ? 1e-10 * sf2 : 10.0 * jitter;
  }
  n_ = 0;  // leave a consistent (empty) model behind
  x_.resize(0, x_.cols());
  x_scaled_.resize(0, x_.cols());
  y_.resize(0);
  beta_.resize(0);
  alpha_.resize(0);
  log_det_ = 0.0;
  return absl::InternalError("Cholesky factorisation failed even with jitter");
}

absl::Status GpModel::AddSample(const Eigen::VectorXd& x, double y) {
  if (x.size() != x_.cols() || x.size() != hyperparameters_.lengthscales.size()) {
    return absl::InvalidArgumentError(
        absl::StrCat("sample has ", x.size(), " inputs, expected ", x_.cols()));
  }
  if (!x.allFinite() || !std::isfinite(y)) {
    return absl::InvalidArgumentError("non-finite sample");
  }
  const int n = n_;
  const Eigen::RowVectorXd s = x.cwiseQuotient(hyperparameters_.lengthscales).transpose();
  // Append the data first; both paths below need it.
  x_.conservativeResize(n + 1, Eigen::NoChange);
  x_.row(n) = x.transpose();
  x_scaled_.conservativeResize(n + 1, Eigen::NoChange);
  x_scaled_.row(n) = s;
  y_.conservativeResize(n + 1);
  y_(n) = y;
  kf_.resize(0, 0);  // stale after an append; recomputed on demand
  if (n == 0) {
    n_ = 1;
    return Factorise();
  }
  const double sf2 = hyperparameters_.signal_variance;
  Eigen::VectorXd l = CrossCovariance(x_scaled_.topRows(n), s, sf2);
  LowerFactor().solveInPlace(l);
  const double d2 = sf2 + hyperparameters_.noise_variance + jitter_ - l.squaredNorm();
  if (!(d2 > 0.0) || !std::isfinite(d2) || !l.allFinite()) {
    n_ = n + 1;
    return Factorise();
  }
  if (l_.rows() < n + 1) {
    // The room Factorise() leaves (25 %): growth stays amortised O(n) per sample
    // and the factor at most (1.25 n + 8)^2 doubles, which memory budgets count
    // on (DynamicsModel::PeakBytes).
    const Eigen::Index capacity = std::max<Eigen::Index>(16, n + 1 + (n + 1) / 4 + 8);
    Eigen::MatrixXd grown(capacity, capacity);
    grown.topLeftCorner(n, n).triangularView<Eigen::Lower>() =
        l_.topLeftCorner(n, n).triangularView<Eigen::Lower>();
    l_.swap(grown);
  }
  const double d = std::sqrt(d2);
  l_.row(n).head(n) = l.transpose();
  l_(n, n) = d;
  beta_.conservativeResize(n + 1);
  beta_(n) = (y - l.dot(beta_.head(n))) / d;
  log_det_ += std::log(d2);
  n_ = n + 1;
  alpha_ = UpperFactor().solve(beta_);
  return absl::OkStatus();
}

Eigen::MatrixXd GpModel::cholesky() const {
  Eigen::MatrixXd l = Eigen::MatrixXd::Zero(n_, n_);
  l.triangularView<Eigen::Lower>() = l_.topLeftCorner(n_, n_);
  return l;
}

double GpModel::log_marginal_likelihood() const {
  return -0.5 * beta_.squaredNorm() - 0.5 * log_det_ - 0.5 * n_ * kLog2Pi;
}

Eigen::VectorXd GpModel::LogMarginalLikelihoodGradient() const {
  const int n = n_;
  const Eigen::Index d = x_.cols();
  Eigen::VectorXd grad(d + 2);
  if (n == 0) return grad.setZero();
  // K_f as cached by the last factorisation, or recomputed after row appends.
  const Eigen::MatrixXd recomputed =
      kf_.rows() == n ? Eigen::MatrixXd()
                      : Covariance(x_scaled_, hyperparameters_.signal_variance);
  const Eigen::MatrixXd& kf = kf_.rows() == n ? kf_ : recomputed;
  // A = W o K_f with W = alpha alpha^T - K^-1, in place of K^-1, one column at a
  // time (n x n temporaries cost page faults and memory traffic at large n).
  Eigen::MatrixXd a = InverseFromCholesky(l_.topLeftCorner(n, n));
  const double trace_w = alpha_.squaredNorm() - a.trace();
  for (int j = 0; j < n; ++j) {
    a.col(j) = (alpha_ * alpha_(j) - a.col(j)).cwiseProduct(kf.col(j));
  }
  grad(0) = 0.5 * a.sum();
  grad.segment(1, d) = LogLengthscaleGradient(a, x_scaled_);
  grad(d + 1) = 0.5 * hyperparameters_.noise_variance * trace_w;
  return grad;
}

void GpModel::Predict(const Eigen::MatrixXd& xs, Eigen::VectorXd* mean,
                      Eigen::VectorXd* variance, Eigen::MatrixXd* mean_jacobian,
                      Eigen::MatrixXd* variance_jacobian) const {
  const Eigen::VectorXd& ls = hyperparameters_.lengthscales;
  const double sf2 = hyperparameters_.signal_variance;
  // K(X, xs), n x m: the layout the triangular solve wants, built without a
  // transposed copy (a batch of 10,000 points at n = 1000 is 80 MB).
  Eigen::MatrixXd v = CrossCovariance(x_scaled_, ScaleInputs(xs, ls), sf2);
  const Eigen::VectorXd inv_l2 = ls.cwiseAbs2().cwiseInverse();
  const Eigen::VectorXd k_alpha = v.transpose() * alpha_;  // the mean
  if (mean_jacobian != nullptr) {
    // d mean_i / d xs_il = -sum_j k_ji alpha_j (xs_il - x_jl) / l_l^2.
    const Eigen::MatrixXd cx = v.transpose() * (alpha_.asDiagonal() * x_);
    *mean_jacobian =
        (cx - xs.cwiseProduct(k_alpha.replicate(1, xs.cols()))) * inv_l2.asDiagonal();
  }
  if (mean != nullptr) *mean = k_alpha;
  if (variance == nullptr && variance_jacobian == nullptr) return;
  if (variance_jacobian == nullptr) {
    SolveLower(l_.topLeftCorner(n_, n_), v);  // V = L \ K(X, xs)
    *variance =
        (sf2 - v.colwise().squaredNorm().array()).cwiseMax(0.0).matrix().transpose();
    return;
  }
  const Eigen::MatrixXd k = v;
  SolveLower(l_.topLeftCorner(n_, n_), v);
  if (variance != nullptr) {
    *variance =
        (sf2 - v.colwise().squaredNorm().array()).cwiseMax(0.0).matrix().transpose();
  }
  // w = L^T \ V = K^-1 K(X, xs); d var_i / d xs_il =
  // 2 sum_j k_ji w_ji (xs_il - x_jl) / l_l^2.
  SolveLowerTransposed(l_.topLeftCorner(n_, n_), v);
  const Eigen::MatrixXd c = k.cwiseProduct(v);  // n x m
  const Eigen::VectorXd c_sums = c.colwise().sum().transpose();
  *variance_jacobian =
      2.0 * (xs.cwiseProduct(c_sums.replicate(1, xs.cols())) - c.transpose() * x_) *
      inv_l2.asDiagonal();
}

Eigen::MatrixXd GpModel::CrossFactor(const Eigen::MatrixXd& xs) const {
  Eigen::MatrixXd v =
      CrossCovariance(x_scaled_, ScaleInputs(xs, hyperparameters_.lengthscales),
                      hyperparameters_.signal_variance);  // n x m
  SolveLower(l_.topLeftCorner(n_, n_), v);
  return v;
}

Eigen::MatrixXd GpModel::PosteriorCovariance(const Eigen::MatrixXd& a,
                                             const Eigen::MatrixXd& a_factor,
                                             const Eigen::MatrixXd& b,
                                             const Eigen::MatrixXd& b_factor) const {
  const Eigen::VectorXd& ls = hyperparameters_.lengthscales;
  Eigen::MatrixXd k = CrossCovariance(ScaleInputs(a, ls), ScaleInputs(b, ls),
                                      hyperparameters_.signal_variance);
  k.noalias() -= a_factor.transpose() * b_factor;
  return k;
}

Eigen::MatrixXd GpModel::PosteriorCovarianceGradient(
    const Eigen::MatrixXd& a, const std::vector<CovarianceTerm>& terms) const {
  const Eigen::VectorXd& ls = hyperparameters_.lengthscales;
  const double sf2 = hyperparameters_.signal_variance;
  const Eigen::MatrixXd sa = ScaleInputs(a, ls);
  Eigen::MatrixXd grad = Eigen::MatrixXd::Zero(a.rows(), a.cols());
  // q = L^T \ sum_t V_bt w_t^T (n x m_a), accumulated before the one solve.
  Eigen::MatrixXd q = Eigen::MatrixXd::Zero(n_, a.rows());
  for (const CovarianceTerm& t : terms) {
    // Prior part: d k(a_i, b_k) / d a_i = -k(a_i, b_k) (a_i - b_k) / l^2, weighted.
    const Eigen::MatrixXd c =
        t.w->cwiseProduct(CrossCovariance(sa, ScaleInputs(*t.b, ls), sf2));
    grad += c * *t.b - a.cwiseProduct(c.rowwise().sum().replicate(1, a.cols()));
    q.noalias() += *t.b_factor * t.w->transpose();
  }
  // Data part: -sum_k w_ik dV_{a_i}^T V_{b_k} = -dK(X, a_i)^T q_i.
  SolveLowerTransposed(l_.topLeftCorner(n_, n_), q);
  const Eigen::MatrixXd e =
      CrossCovariance(sa, x_scaled_, sf2).cwiseProduct(q.transpose());
  grad += a.cwiseProduct(e.rowwise().sum().replicate(1, a.cols())) - e * x_;
  return grad * ls.cwiseAbs2().cwiseInverse().asDiagonal();
}

}  // namespace excite::gp
