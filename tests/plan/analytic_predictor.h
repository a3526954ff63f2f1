#ifndef EXCITE_TESTS_PLAN_ANALYTIC_PREDICTOR_H_
#define EXCITE_TESTS_PLAN_ANALYTIC_PREDICTOR_H_

#include <Eigen/Dense>
#include <chrono>
#include <cmath>
#include <thread>
#include <vector>

#include "server/gp/dynamics_predictor.h"

namespace excite::plan::testing {

// A closed-form stand-in for a GP dynamics model, so planner tests do not depend
// on the GP engine. Mean: a semi-implicit Euler step of a damped pendulum
// (state (theta, omega)); with input_dim 2 the second input acts on theta through
// a sine, so every Jacobian block is non-trivial. Variance of output j: a floor
// plus a term that grows with the distance from a few fixed "data" points,
//   var_j(z) = v0_j + s_j (1 - 1/K sum_k exp(-1/2 sum_l ((z_l - c_kl) / ell_jl)^2)),
// bounded and smooth, like a GP's latent variance.
class AnalyticPendulum : public gp::DynamicsPredictor {
 public:
  explicit AnalyticPendulum(int input_dim = 1) : du_(input_dim) {
    const int zd = 2 + du_;
    centers_ = Eigen::MatrixXd::Zero(4, zd);
    centers_.row(1).head(3) << 0.3, -0.5, 0.5;
    centers_.row(2).head(3) << -0.4, 0.8, -1.0;
    centers_.row(3).head(3) << 0.1, 0.2, 0.8;
    lengthscales_.resize(2, zd);
    for (int l = 0; l < zd; ++l) {
      lengthscales_(0, l) = 0.8 + 0.25 * l;
      lengthscales_(1, l) = 1.1 - 0.15 * l;
    }
  }

  int state_dim() const override { return 2; }
  int input_dim() const override { return du_; }

  void Predict(const Eigen::MatrixXd& z, Eigen::MatrixXd* mean, Eigen::MatrixXd* variance,
               std::vector<Eigen::MatrixXd>* mean_jacobians,
               std::vector<Eigen::MatrixXd>* variance_jacobians) const override {
    const int m = static_cast<int>(z.rows());
    const int zd = 2 + du_;
    // Null outputs are not wanted (DynamicsPredictor); compute into locals.
    Eigen::MatrixXd unwanted_mean, unwanted_variance;
    if (mean == nullptr) mean = &unwanted_mean;
    if (variance == nullptr) variance = &unwanted_variance;
    mean->resize(m, 2);
    variance->resize(m, 2);
    if (mean_jacobians != nullptr)
      mean_jacobians->assign(m, Eigen::MatrixXd::Zero(2, zd));
    if (variance_jacobians != nullptr) {
      variance_jacobians->assign(m, Eigen::MatrixXd::Zero(2, zd));
    }
    for (int i = 0; i < m; ++i) {
      const double theta = z(i, 0);
      const double omega = z(i, 1);
      const double u0 = z(i, 2);
      const double u1 = du_ > 1 ? z(i, 3) : 0.0;
      const double omega_next =
          omega + kDt * (-kGl * std::sin(theta) - kDamping * omega + kGain * u0);
      const double theta_next = theta + kDt * omega_next + kDt * kGain2 * std::sin(u1);
      (*mean)(i, 0) = theta_next;
      (*mean)(i, 1) = omega_next;
      if (mean_jacobians != nullptr) {
        Eigen::MatrixXd& j = (*mean_jacobians)[i];
        j(1, 0) = -kDt * kGl * std::cos(theta);
        j(1, 1) = 1.0 - kDt * kDamping;
        j(1, 2) = kDt * kGain;
        j(0, 0) = 1.0 + kDt * j(1, 0);
        j(0, 1) = kDt * j(1, 1);
        j(0, 2) = kDt * j(1, 2);
        if (du_ > 1) j(0, 3) = kDt * kGain2 * std::cos(u1);
      }
      for (int out = 0; out < 2; ++out) {
        double sum = 0.0;
        Eigen::RowVectorXd dsum = Eigen::RowVectorXd::Zero(zd);
        for (int k = 0; k < centers_.rows(); ++k) {
          const Eigen::RowVectorXd d =
              (z.row(i) - centers_.row(k)).cwiseQuotient(lengthscales_.row(out));
          const double e = std::exp(-0.5 * d.squaredNorm());
          sum += e;
          dsum -= e * d.cwiseQuotient(lengthscales_.row(out));
        }
        const double scale = kSignal[out] / static_cast<double>(centers_.rows());
        (*variance)(i, out) = kFloor[out] + kSignal[out] - scale * sum;
        if (variance_jacobians != nullptr) {
          (*variance_jacobians)[i].row(out) = -scale * dsum;
        }
      }
    }
  }

 private:
  static constexpr double kDt = 0.1;
  static constexpr double kGl = 9.81;
  static constexpr double kDamping = 0.5;
  static constexpr double kGain = 2.0;
  static constexpr double kGain2 = 0.3;
  static constexpr double kFloor[2] = {1e-3, 2e-3};
  static constexpr double kSignal[2] = {0.5, 1.0};
  int du_;
  Eigen::MatrixXd centers_;
  Eigen::MatrixXd lengthscales_;
};

// Wraps a predictor and corrupts its derivatives (to check that the derivative
// checks can fail) and/or sleeps `delay` per predicted point (to test deadlines).
class WrappedPredictor : public gp::DynamicsPredictor {
 public:
  WrappedPredictor(const gp::DynamicsPredictor& inner, double mean_jacobian_scale,
                   double variance_jacobian_scale,
                   std::chrono::microseconds delay = std::chrono::microseconds(0))
      : inner_(inner),
        mean_scale_(mean_jacobian_scale),
        variance_scale_(variance_jacobian_scale),
        delay_(delay) {}

  int state_dim() const override { return inner_.state_dim(); }
  int input_dim() const override { return inner_.input_dim(); }
  void Predict(const Eigen::MatrixXd& z, Eigen::MatrixXd* mean, Eigen::MatrixXd* variance,
               std::vector<Eigen::MatrixXd>* mean_jacobians,
               std::vector<Eigen::MatrixXd>* variance_jacobians) const override {
    if (delay_.count() > 0) std::this_thread::sleep_for(delay_ * z.rows());
    inner_.Predict(z, mean, variance, mean_jacobians, variance_jacobians);
    if (mean_jacobians != nullptr) {
      for (auto& j : *mean_jacobians) j *= mean_scale_;
    }
    if (variance_jacobians != nullptr) {
      for (auto& j : *variance_jacobians) j *= variance_scale_;
    }
  }

 private:
  const gp::DynamicsPredictor& inner_;
  double mean_scale_;
  double variance_scale_;
  std::chrono::microseconds delay_;
};

}  // namespace excite::plan::testing

#endif  // EXCITE_TESTS_PLAN_ANALYTIC_PREDICTOR_H_
