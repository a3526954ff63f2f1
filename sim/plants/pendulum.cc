#include "sim/plants/pendulum.h"

#include <cmath>

#include "sim/plants/rk4.h"

namespace excite::sim {

Pendulum::Pendulum(const PendulumParameters& parameters, double dt_s, int substeps)
    : parameters_(parameters), dt_s_(dt_s), substeps_(substeps) {}

Eigen::Vector2d Pendulum::Derivative(const Eigen::Vector2d& x, double u) const {
  const double m = parameters_.mass_kg;
  const double l = parameters_.length_m;
  const double inertia = m * l * l;
  const double acceleration = -(parameters_.gravity / l) * std::sin(x(0)) -
                              (parameters_.damping / inertia) * x(1) + u / inertia;
  return {x(1), acceleration};
}

double Pendulum::Energy(const Eigen::Vector2d& x) const {
  const double m = parameters_.mass_kg;
  const double l = parameters_.length_m;
  return 0.5 * m * l * l * x(1) * x(1) +
         m * parameters_.gravity * l * (1.0 - std::cos(x(0)));
}

Eigen::VectorXd Pendulum::Step(const Eigen::VectorXd& x, const Eigen::VectorXd& u) const {
  const double torque = u(0);
  const auto f = [this, torque](const Eigen::VectorXd& state) -> Eigen::VectorXd {
    return Derivative(Eigen::Vector2d(state(0), state(1)), torque);
  };
  return Rk4Integrate(f, x, dt_s_, substeps_);
}

}  // namespace excite::sim
