#ifndef EXCITE_TESTS_GP_REFERENCE_GP_H_
#define EXCITE_TESTS_GP_REFERENCE_GP_H_

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <utility>

#include "gtest/gtest.h"
#include "server/gp/hyperparameters.h"

namespace excite::gp::testing {

// A deliberately naive GP used as an independent reference: dense K built with
// scalar loops, every solve by full-pivoting LU, nothing cached or reused.
// Constant prior mean `prior_mean`.
class ReferenceGp {
 public:
  ReferenceGp(Eigen::MatrixXd x, Eigen::VectorXd y, Hyperparameters h,
              double prior_mean = 0.0)
      : x_(std::move(x)), y_(std::move(y)), h_(std::move(h)), m0_(prior_mean) {
    const int n = static_cast<int>(x_.rows());
    Eigen::MatrixXd k(n, n);
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < n; ++j) k(i, j) = Kernel(x_.row(i), x_.row(j));
      k(i, i) += h_.noise_variance;
    }
    lu_ = Eigen::FullPivLU<Eigen::MatrixXd>(k);
  }

  double Kernel(const Eigen::RowVectorXd& a, const Eigen::RowVectorXd& b) const {
    double s = 0.0;
    for (int l = 0; l < a.size(); ++l) {
      const double d = (a(l) - b(l)) / h_.lengthscales(l);
      s += d * d;
    }
    return h_.signal_variance * std::exp(-0.5 * s);
  }

  Eigen::VectorXd KStar(const Eigen::RowVectorXd& xs) const {
    Eigen::VectorXd k(x_.rows());
    for (int i = 0; i < x_.rows(); ++i) k(i) = Kernel(xs, x_.row(i));
    return k;
  }

  double Mean(const Eigen::RowVectorXd& xs) const {
    const Eigen::VectorXd r = y_.array() - m0_;
    return m0_ + KStar(xs).dot(lu_.solve(r));
  }

  double Variance(const Eigen::RowVectorXd& xs) const {
    const Eigen::VectorXd k = KStar(xs);
    return h_.signal_variance - k.dot(lu_.solve(k));
  }

  double LogMarginalLikelihood() const {
    const Eigen::VectorXd r = y_.array() - m0_;
    double log_det = 0.0;
    const Eigen::MatrixXd& lu = lu_.matrixLU();
    for (int i = 0; i < lu.rows(); ++i) log_det += std::log(std::abs(lu(i, i)));
    return -0.5 * r.dot(lu_.solve(r)) - 0.5 * log_det -
           0.5 * static_cast<double>(y_.size()) * std::log(2.0 * 3.14159265358979323846);
  }

 private:
  Eigen::MatrixXd x_;
  Eigen::VectorXd y_;
  Hyperparameters h_;
  double m0_;
  Eigen::FullPivLU<Eigen::MatrixXd> lu_;
};

struct Data {
  Eigen::MatrixXd x;
  Eigen::VectorXd y;
};

// n points uniform in [-1, 1]^d, a smooth target plus N(0, noise^2).
inline Data MakeData(int n, int d, uint64_t seed, double noise = 0.1) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> e(0.0, noise);
  Data data{Eigen::MatrixXd(n, d), Eigen::VectorXd(n)};
  for (int i = 0; i < n; ++i) {
    for (int l = 0; l < d; ++l) data.x(i, l) = u(rng);
    data.y(i) = std::sin(2.0 * data.x(i, 0)) + 0.5 * data.x.row(i).squaredNorm() + e(rng);
  }
  return data;
}

inline Hyperparameters MakeHyperparameters(int d) {
  Hyperparameters h;
  h.signal_variance = 1.3;
  h.lengthscales = Eigen::VectorXd::LinSpaced(d, 0.6, 1.4);
  h.noise_variance = 0.05;
  return h;
}

// Relative difference with an absolute floor.
inline double RelErr(double a, double b, double floor = 1e-12) {
  return std::abs(a - b) / std::max({std::abs(a), std::abs(b), floor});
}

// The mean and variance Jacobians `model` predicts at the rows of x (GpModel or
// SparseGpModel) against central differences of its own predictions.
template <typename Model>
void ExpectJacobiansMatchFiniteDifferences(const Model& model, const Eigen::MatrixXd& x) {
  Eigen::VectorXd mean, var;
  Eigen::MatrixXd dmean, dvar;
  model.Predict(x, &mean, &var, &dmean, &dvar);
  const double eps = 1e-6;
  for (Eigen::Index l = 0; l < x.cols(); ++l) {
    Eigen::MatrixXd plus = x, minus = x;
    plus.col(l).array() += eps;
    minus.col(l).array() -= eps;
    Eigen::VectorXd mp, vp, mm, vm;
    model.Predict(plus, &mp, &vp, nullptr, nullptr);
    model.Predict(minus, &mm, &vm, nullptr, nullptr);
    for (Eigen::Index i = 0; i < x.rows(); ++i) {
      EXPECT_LT(RelErr(dmean(i, l), (mp(i) - mm(i)) / (2 * eps), 1e-3), 1e-6);
      EXPECT_LT(RelErr(dvar(i, l), (vp(i) - vm(i)) / (2 * eps), 1e-3), 1e-6);
    }
  }
}

}  // namespace excite::gp::testing

#endif  // EXCITE_TESTS_GP_REFERENCE_GP_H_
