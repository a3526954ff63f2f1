#include "server/gp/sparse_gp_model.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "server/gp/dense_linear_algebra.h"
#include "server/gp/kernel.h"

namespace excite::gp {
namespace {

// Data is visited in blocks of this many samples, so that the M x block kernel
// matrices stay small (2 MiB at M = 256).
constexpr Eigen::Index kBlock = 1024;

bool PositiveFinite(double v) { return std::isfinite(v) && v > 0.0; }

// L L^T + v v^T = L' L'^T in place (lower L, m x m), O(m^2); v is consumed.
void CholeskyRankOneUpdate(Eigen::Ref<Eigen::MatrixXd> l, Eigen::VectorXd v) {
  const Eigen::Index m = l.rows();
  for (Eigen::Index k = 0; k < m; ++k) {
    const double lkk = l(k, k);
    const double r = std::hypot(lkk, v(k));
    const double c = r / lkk;
    const double s = v(k) / lkk;
    l(k, k) = r;
    const Eigen::Index rest = m - k - 1;
    if (rest == 0) break;
    auto column = l.col(k).tail(rest);
    auto tail = v.tail(rest);
    column = (column + s * tail) / c;
    tail = c * tail - s * column;
  }
}

}  // namespace

SparseGpModel::SparseGpModel(SparseGpOptions options) : options_(options) {}

absl::Status SparseGpModel::Reset(Eigen::MatrixXd x, Eigen::VectorXd y,
                                  const Hyperparameters& hyperparameters) {
  if (options_.max_inducing < 1 || !(options_.inducing_tolerance > 0.0) ||
      !std::isfinite(options_.inducing_tolerance)) {
    return absl::InvalidArgumentError(
        "sparse GP: max_inducing must be >= 1 and inducing_tolerance finite and > 0");
  }
  if (x.rows() != y.size()) {
    return absl::InvalidArgumentError(
        absl::StrCat("x has ", x.rows(), " rows but y has ", y.size(), " entries"));
  }
  const Hyperparameters& h = hyperparameters;
  bool valid = h.lengthscales.size() == x.cols() && PositiveFinite(h.signal_variance) &&
               PositiveFinite(h.noise_variance);
  for (Eigen::Index l = 0; valid && l < h.lengthscales.size(); ++l) {
    valid = PositiveFinite(h.lengthscales(l));
  }
  if (!valid) {
    return absl::InvalidArgumentError(
        absl::StrCat("expected ", x.cols(),
                     " finite positive lengthscales and finite positive "
                     "signal and noise variances"));
  }
  if (!x.allFinite() || !y.allFinite()) {
    return absl::InvalidArgumentError("non-finite data");
  }
  hyperparameters_ = h;
  x_ = std::move(x);
  y_ = std::move(y);
  x_scaled_ = ScaleInputs(x_, h.lengthscales);
  const Eigen::Index n = x_.rows();
  const int capacity = options_.max_inducing;
  m_ = 0;
  inducing_.resize(capacity);
  z_scaled_.resize(capacity, x_.cols());
  l_.setZero(capacity, capacity);
  lb_.setZero(capacity, capacity);

  // Z first, from L alone: sample i is tested against the points chosen before
  // it, exactly as AddSample() would.
  const double sf2 = h.signal_variance;
  const double threshold = options_.inducing_tolerance * h.noise_variance;
  for (Eigen::Index i = 0; i < n && m_ < capacity; ++i) {
    Eigen::VectorXd l = CrossCovariance(z_scaled_.topRows(m_), x_scaled_.row(i), sf2);
    l_.topLeftCorner(m_, m_).triangularView<Eigen::Lower>().solveInPlace(l);
    const double d2 = sf2 - l.squaredNorm();
    if (!(d2 > threshold)) continue;
    l_.row(m_).head(m_) = l.transpose();
    l_(m_, m_) = std::sqrt(d2);
    z_scaled_.row(m_) = x_scaled_.row(i);
    inducing_(m_) = static_cast<int>(i);
    ++m_;
  }
  // Then B = I + A A^T, A y and A 1 by blocks of A = L^-1 K(Z, X) / sigma_n.
  const double sn = std::sqrt(h.noise_variance);
  Eigen::MatrixXd b = Eigen::MatrixXd::Identity(m_, m_);
  ay_.setZero(m_);
  a1_.setZero(m_);
  for (Eigen::Index start = 0; start < n; start += kBlock) {
    const Eigen::Index count = std::min(kBlock, n - start);
    Eigen::MatrixXd a =
        CrossCovariance(z_scaled_.topRows(m_), x_scaled_.middleRows(start, count), sf2) /
        sn;
    SolveLower(l_.topLeftCorner(m_, m_), a);
    // No inducing points (a signal too weak to need one: the prior) leaves B
    // empty, and Eigen's rank update binds a reference to its null data (UBSan).
    if (m_ > 0) b.selfadjointView<Eigen::Lower>().rankUpdate(a);
    ay_.noalias() += a * y_.segment(start, count) / sn;
    a1_.noalias() += a.rowwise().sum() / sn;
  }
  lb_.topLeftCorner(m_, m_).triangularView<Eigen::Lower>() = b;
  // B >= I, so its factorisation cannot fail.
  CholeskyInPlace(lb_.topLeftCorner(m_, m_));
  UpdateWeights();
  return absl::OkStatus();
}

absl::Status SparseGpModel::CheckSample(const Eigen::VectorXd& x, double y) const {
  if (hyperparameters_.lengthscales.size() == 0) {
    return absl::FailedPreconditionError("sparse GP: Reset() first");
  }
  if (x.size() != x_.cols()) {
    return absl::InvalidArgumentError(
        absl::StrCat("sample has ", x.size(), " inputs, expected ", x_.cols()));
  }
  if (!x.allFinite() || !std::isfinite(y)) {
    return absl::InvalidArgumentError("non-finite sample");
  }
  return absl::OkStatus();
}

absl::Status SparseGpModel::AddSample(const Eigen::VectorXd& x, double y) {
  if (absl::Status s = CheckSample(x, y); !s.ok()) return s;
  const Eigen::Index n = x_.rows();
  x_.conservativeResize(n + 1, Eigen::NoChange);
  x_.row(n) = x.transpose();
  x_scaled_.conservativeResize(n + 1, Eigen::NoChange);
  x_scaled_.row(n) = x.cwiseQuotient(hyperparameters_.lengthscales).transpose();
  y_.conservativeResize(n + 1);
  y_(n) = y;
  MaybeAddInducing(static_cast<int>(n));
  AddToProducts(static_cast<int>(n));
  UpdateWeights();
  return absl::OkStatus();
}

void SparseGpModel::MaybeAddInducing(int index) {
  if (m_ == options_.max_inducing) return;
  const double sf2 = hyperparameters_.signal_variance;
  const double sn = std::sqrt(hyperparameters_.noise_variance);
  const auto s = x_scaled_.row(index);
  const auto z = z_scaled_.topRows(m_);
  const auto l_old = l_.topLeftCorner(m_, m_).triangularView<Eigen::Lower>();
  Eigen::VectorXd l = CrossCovariance(z, s, sf2);
  l_old.solveInPlace(l);
  const double d2 = sf2 - l.squaredNorm();
  if (!(d2 > options_.inducing_tolerance * hyperparameters_.noise_variance)) return;
  const double d = std::sqrt(d2);
  // The new row of A over the samples before `index`:
  // a = (K(s, X) - l^T L^-1 K(Z, X)) / (sigma_n d), and A_old a^T for B's new
  // column, in one pass over the data.
  const Eigen::VectorXd q = l_old.transpose().solve(l);
  Eigen::VectorXd kza = Eigen::VectorXd::Zero(m_);  // K(Z, X) a
  double ay = 0.0, a1 = 0.0, aa = 0.0;
  for (Eigen::Index start = 0; start < index; start += kBlock) {
    const Eigen::Index count = std::min<Eigen::Index>(kBlock, index - start);
    const auto xb = x_scaled_.middleRows(start, count);
    const Eigen::MatrixXd kzx = CrossCovariance(z, xb, sf2);  // m x count
    const Eigen::VectorXd a =
        (CrossCovariance(xb, s, sf2) - kzx.transpose() * q) / (sn * d);
    kza.noalias() += kzx * a;
    ay += a.dot(y_.segment(start, count));
    a1 += a.sum();
    aa += a.squaredNorm();
  }
  Eigen::VectorXd b = kza / sn;  // A_old a^T
  l_old.solveInPlace(b);
  const auto lb_old = lb_.topLeftCorner(m_, m_).triangularView<Eigen::Lower>();
  lb_old.solveInPlace(b);
  // The Schur complement of B's new pivot is >= 1 (B' >= I); rounding can only
  // nudge it.
  const double db2 = std::max(1.0 + aa - b.squaredNorm(), 1.0);
  lb_.row(m_).head(m_) = b.transpose();
  lb_(m_, m_) = std::sqrt(db2);
  l_.row(m_).head(m_) = l.transpose();
  l_(m_, m_) = d;
  z_scaled_.row(m_) = s;
  inducing_(m_) = index;
  ay_.conservativeResize(m_ + 1);
  ay_(m_) = ay / sn;
  a1_.conservativeResize(m_ + 1);
  a1_(m_) = a1 / sn;
  ++m_;
}

void SparseGpModel::AddToProducts(int index) {
  const double sn = std::sqrt(hyperparameters_.noise_variance);
  Eigen::VectorXd a = CrossCovariance(z_scaled_.topRows(m_), x_scaled_.row(index),
                                      hyperparameters_.signal_variance) /
                      sn;
  l_.topLeftCorner(m_, m_).triangularView<Eigen::Lower>().solveInPlace(a);
  ay_ += a * (y_(index) / sn);
  a1_ += a / sn;
  CholeskyRankOneUpdate(lb_.topLeftCorner(m_, m_), std::move(a));
}

void SparseGpModel::ShiftTargets(double delta) {
  y_.array() -= delta;
  ay_ -= delta * a1_;
  UpdateWeights();
}

void SparseGpModel::UpdateWeights() {
  weights_ = lb_.topLeftCorner(m_, m_).triangularView<Eigen::Lower>().solve(ay_);
  lb_.topLeftCorner(m_, m_).transpose().triangularView<Eigen::Upper>().solveInPlace(
      weights_);
  l_.topLeftCorner(m_, m_).transpose().triangularView<Eigen::Upper>().solveInPlace(
      weights_);
}

Eigen::MatrixXd SparseGpModel::kernel_factor() const {
  Eigen::MatrixXd l = Eigen::MatrixXd::Zero(m_, m_);
  l.triangularView<Eigen::Lower>() = l_.topLeftCorner(m_, m_);
  return l;
}

Eigen::MatrixXd SparseGpModel::b_factor() const {
  Eigen::MatrixXd l = Eigen::MatrixXd::Zero(m_, m_);
  l.triangularView<Eigen::Lower>() = lb_.topLeftCorner(m_, m_);
  return l;
}

void SparseGpModel::Predict(const Eigen::MatrixXd& xs, Eigen::VectorXd* mean,
                            Eigen::VectorXd* variance, Eigen::MatrixXd* mean_jacobian,
                            Eigen::MatrixXd* variance_jacobian) const {
  const Eigen::VectorXd& ls = hyperparameters_.lengthscales;
  const double sf2 = hyperparameters_.signal_variance;
  const Eigen::VectorXd inv_l2 = ls.cwiseAbs2().cwiseInverse();
  const auto z_scaled = z_scaled_.topRows(m_);
  // Z in data units, for the Jacobians' differences xs - z.
  const Eigen::MatrixXd z = z_scaled * ls.asDiagonal();
  const Eigen::MatrixXd k = CrossCovariance(z_scaled, ScaleInputs(xs, ls), sf2);  // m x p
  const Eigen::VectorXd k_w = k.transpose() * weights_;
  if (mean_jacobian != nullptr) {
    const Eigen::MatrixXd cz = k.transpose() * (weights_.asDiagonal() * z);
    *mean_jacobian =
        (cz - xs.cwiseProduct(k_w.replicate(1, xs.cols()))) * inv_l2.asDiagonal();
  }
  if (mean != nullptr) *mean = k_w;
  if (variance == nullptr && variance_jacobian == nullptr) return;
  Eigen::MatrixXd v1 = k;
  SolveLower(l_.topLeftCorner(m_, m_), v1);  // L^-1 k
  Eigen::MatrixXd v2 = v1;
  SolveLower(lb_.topLeftCorner(m_, m_), v2);  // L_B^-1 L^-1 k
  if (variance != nullptr) {
    *variance =
        (sf2 - v1.colwise().squaredNorm().array() + v2.colwise().squaredNorm().array())
            .cwiseMax(0.0)
            .matrix()
            .transpose();
  }
  if (variance_jacobian == nullptr) return;
  // var = k** - k^T P k with P = Kzz^-1 - L^-T B^-1 L^-1, so
  // d var / d xs = -2 (P k)^T dk with P k = L^-T (V1 - L_B^-T V2).
  SolveLowerTransposed(lb_.topLeftCorner(m_, m_), v2);
  v1 -= v2;
  SolveLowerTransposed(l_.topLeftCorner(m_, m_), v1);
  const Eigen::MatrixXd c = k.cwiseProduct(v1);  // m x p
  const Eigen::VectorXd c_sums = c.colwise().sum().transpose();
  *variance_jacobian =
      2.0 * (xs.cwiseProduct(c_sums.replicate(1, xs.cols())) - c.transpose() * z) *
      inv_l2.asDiagonal();
}

int64_t SparseGpModel::FactorBytes(int max_inducing, int dim) {
  // L and L_B, Z (allocated at full capacity) and three m-vectors.
  const int64_t m = max_inducing;
  return static_cast<int64_t>(sizeof(double)) * (2 * m * m + m * dim + 3 * m) +
         static_cast<int64_t>(sizeof(int)) * m;
}

int64_t SparseGpModel::WorkspaceBytes(int max_inducing) {
  const int64_t m = max_inducing;
  return static_cast<int64_t>(sizeof(double)) * (2 * m * kBlock + m * m);
}

}  // namespace excite::gp
