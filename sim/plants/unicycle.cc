#include "sim/plants/unicycle.h"

#include <cmath>

#include "sim/plants/rk4.h"

namespace excite::sim {

Unicycle::Unicycle(const UnicycleParameters& parameters, double dt_s, int substeps)
    : parameters_(parameters), dt_s_(dt_s), substeps_(substeps) {}

Eigen::VectorXd Unicycle::Derivative(const Eigen::VectorXd& x,
                                     const Eigen::Vector2d& u) const {
  const UnicycleParameters& p = parameters_;
  const double psi = x(2);
  const double v = x(3);
  const double w = x(4);
  const double r = x(5);
  const double force = u(0) + u(1);
  const double torque = p.half_track_m * (u(1) - u(0));
  const double c = std::cos(psi);
  const double s = std::sin(psi);
  Eigen::VectorXd derivative(6);
  derivative << v * c - w * s, v * s + w * c, r,
      (force - p.forward_damping * v) / p.mass_kg + w * r,
      -p.lateral_damping * w / p.mass_kg - v * r,
      (torque - p.yaw_damping * r) / p.yaw_inertia;
  return derivative;
}

double Unicycle::KineticEnergy(const Eigen::VectorXd& x) const {
  return 0.5 * parameters_.mass_kg * (x(3) * x(3) + x(4) * x(4)) +
         0.5 * parameters_.yaw_inertia * x(5) * x(5);
}

Eigen::VectorXd Unicycle::Step(const Eigen::VectorXd& x, const Eigen::VectorXd& u) const {
  const Eigen::Vector2d forces(u(0), u(1));
  const auto f = [this, &forces](const Eigen::VectorXd& state) -> Eigen::VectorXd {
    return Derivative(state, forces);
  };
  return Rk4Integrate(f, x, dt_s_, substeps_);
}

}  // namespace excite::sim
