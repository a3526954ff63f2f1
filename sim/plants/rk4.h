#ifndef EXCITE_SIM_PLANTS_RK4_H_
#define EXCITE_SIM_PLANTS_RK4_H_

#include <Eigen/Dense>

namespace excite::sim {

// Classic fourth-order Runge-Kutta for an autonomous ODE x' = f(x).
// `f` is any callable `Eigen::VectorXd(const Eigen::VectorXd&)`; a plant holds its
// input constant over a sampling period by capturing it in `f`. The global error over
// a fixed interval is O(h^4). Pure function of its arguments: thread-safe if `f` is.

// One RK4 step of size h from x.
template <typename F>
Eigen::VectorXd Rk4Step(const F& f, const Eigen::VectorXd& x, double h) {
  const Eigen::VectorXd k1 = f(x);
  const Eigen::VectorXd k2 = f(x + 0.5 * h * k1);
  const Eigen::VectorXd k3 = f(x + 0.5 * h * k2);
  const Eigen::VectorXd k4 = f(x + h * k3);
  return x + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
}

// Integrates from x over `duration` with `steps` equal RK4 steps (steps >= 1;
// callers validate it).
template <typename F>
Eigen::VectorXd Rk4Integrate(const F& f, const Eigen::VectorXd& x, double duration,
                             int steps) {
  const double h = duration / steps;
  Eigen::VectorXd state = x;
  for (int i = 0; i < steps; ++i) state = Rk4Step(f, state, h);
  return state;
}

}  // namespace excite::sim

#endif  // EXCITE_SIM_PLANTS_RK4_H_
