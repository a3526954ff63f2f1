#ifndef EXCITE_SIM_PLANTS_PENDULUM_H_
#define EXCITE_SIM_PLANTS_PENDULUM_H_

#include <Eigen/Dense>
#include <string>

#include "sim/plants/plant.h"

namespace excite::sim {

// Physical parameters of a damped pendulum driven by a torque at its pivot (SI).
struct PendulumParameters {
  double mass_kg = 1.0;
  double length_m = 1.0;
  double damping = 0.1;   // b, N m s / rad.
  double gravity = 9.81;  // g, m / s^2.
};

// theta'' = -(g/l) sin(theta) - b/(m l^2) theta' + u/(m l^2).
// State x = (theta [rad], theta' [rad/s]) with theta = 0 hanging down (stable) and
// not wrapped; input u = torque [N m] held over one sampling period dt, integrated
// with `substeps` RK4 steps. Parameters must be positive (damping >= 0) and
// substeps >= 1: the factory checks them (plant_factory.h). Thread-safe.
class Pendulum : public Plant {
 public:
  Pendulum(const PendulumParameters& parameters, double dt_s, int substeps);

  std::string name() const override { return "pendulum"; }
  int state_dim() const override { return 2; }
  int input_dim() const override { return 1; }
  Eigen::VectorXd Step(const Eigen::VectorXd& x, const Eigen::VectorXd& u) const override;

  // The continuous-time vector field (theta', theta'') at x under torque u.
  Eigen::Vector2d Derivative(const Eigen::Vector2d& x, double u) const;
  // Mechanical energy m l^2 theta'^2 / 2 + m g l (1 - cos theta) [J]; 0 at rest
  // hanging down.
  double Energy(const Eigen::Vector2d& x) const;

  const PendulumParameters& parameters() const { return parameters_; }
  double dt_s() const { return dt_s_; }
  int substeps() const { return substeps_; }

 private:
  PendulumParameters parameters_;
  double dt_s_;
  int substeps_;
};

}  // namespace excite::sim

#endif  // EXCITE_SIM_PLANTS_PENDULUM_H_
