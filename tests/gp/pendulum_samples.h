#ifndef EXCITE_TESTS_GP_PENDULUM_SAMPLES_H_
#define EXCITE_TESTS_GP_PENDULUM_SAMPLES_H_

#include <Eigen/Dense>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "server/gp/hyperparameters.h"

namespace excite::gp::testing {

// A damped pendulum, state (angle, rate), input torque; dt = 0.1. Its angle is
// not wrapped: a turn adds 2 pi.
inline Eigen::Vector2d PendulumStep(const Eigen::Vector2d& x, double u) {
  const double dt = 0.1;
  return {x(0) + dt * x(1), x(1) + dt * (-9.81 * std::sin(x(0)) - 0.2 * x(1) + u)};
}

struct Transitions {
  Eigen::MatrixXd x, u, next;
};

// n noisy transitions (noise variance `noise_var` on state and next state) from
// angles in [angle_lo, angle_hi], rates in [-6, 6], torques in [-2, 2].
inline Transitions PendulumTransitions(int n, uint64_t seed, double noise_var,
                                       double angle_lo = -3.0, double angle_hi = 3.0) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> a(angle_lo, angle_hi), r(-6.0, 6.0),
      t(-2.0, 2.0);
  std::normal_distribution<double> e(0.0, std::sqrt(noise_var));
  Transitions d{Eigen::MatrixXd(n, 2), Eigen::MatrixXd(n, 1), Eigen::MatrixXd(n, 2)};
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector2d x(a(rng), r(rng));
    d.u(i, 0) = t(rng);
    const Eigen::Vector2d y = PendulumStep(x, d.u(i, 0));
    d.x.row(i) = (x + Eigen::Vector2d(e(rng), e(rng))).transpose();
    d.next.row(i) = (y + Eigen::Vector2d(e(rng), e(rng))).transpose();
  }
  return d;
}

// The model inputs z = (x, u) of the transitions.
inline Eigen::MatrixXd Z(const Transitions& d) {
  Eigen::MatrixXd z(d.x.rows(), 3);
  z << d.x, d.u;
  return z;
}

// Fixed, well-conditioned hyperparameters of the two pendulum outputs in data
// units (z = (theta, omega, u)).
inline std::vector<Hyperparameters> DataUnitHyperparameters() {
  Hyperparameters a, b;
  a.signal_variance = 0.5;
  a.lengthscales = Eigen::Vector3d(2.0, 4.0, 3.0);
  a.noise_variance = 2e-3;
  b.signal_variance = 2.0;
  b.lengthscales = Eigen::Vector3d(1.5, 6.0, 2.5);
  b.noise_variance = 3e-3;
  return {a, b};
}

}  // namespace excite::gp::testing

#endif  // EXCITE_TESTS_GP_PENDULUM_SAMPLES_H_
