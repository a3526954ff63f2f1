#ifndef EXCITE_SIM_PLANTS_UNICYCLE_H_
#define EXCITE_SIM_PLANTS_UNICYCLE_H_

#include <Eigen/Dense>
#include <string>

#include "sim/plants/plant.h"

namespace excite::sim {

// Physical parameters of a planar unicycle / differential-drive vehicle (SI).
struct UnicycleParameters {
  double mass_kg = 1.0;
  double yaw_inertia = 0.05;     // I_z, kg m^2.
  double half_track_m = 0.2;     // Distance of each wheel from the centre, m.
  double forward_damping = 1.0;  // b_v, N s / m.
  double lateral_damping = 4.0;  // b_w, N s / m: sideways (tyre) slip damping.
  double yaw_damping = 0.2;      // b_r, N m s / rad.
};

// A dynamic unicycle driven by the forces of its two wheels, with viscous damping of
// every body-frame velocity. State x = (px, py, psi, v, w, r): position [m] in the
// world frame, heading psi [rad] (not wrapped), forward speed v and lateral (slip)
// speed w [m/s] in the body frame, yaw rate r [rad/s]. Input u = (F_left, F_right)
// [N]; F = F_left + F_right drives, tau = half_track (F_right - F_left) turns:
//   px' = v cos psi - w sin psi,   py' = v sin psi + w cos psi,   psi' = r,
//   m (v' - w r) = F - b_v v,      m (w' + v r) = -b_w w,          I r' = tau - b_r r.
// The lateral damping is a tyre that resists sideways slip; as b_w -> infinity w -> 0
// and this becomes the nonholonomic unicycle (Udwadia and Kalaba). Held input,
// `substeps` RK4 steps per period dt; the factory checks the parameters. Thread-safe.
class Unicycle : public Plant {
 public:
  Unicycle(const UnicycleParameters& parameters, double dt_s, int substeps);

  std::string name() const override { return "unicycle"; }
  int state_dim() const override { return 6; }
  int input_dim() const override { return 2; }
  Eigen::VectorXd Step(const Eigen::VectorXd& x, const Eigen::VectorXd& u) const override;

  // The continuous-time vector field at x under wheel forces u.
  Eigen::VectorXd Derivative(const Eigen::VectorXd& x, const Eigen::Vector2d& u) const;
  // Kinetic energy m (v^2 + w^2) / 2 + I_z r^2 / 2 [J].
  double KineticEnergy(const Eigen::VectorXd& x) const;

  const UnicycleParameters& parameters() const { return parameters_; }
  double dt_s() const { return dt_s_; }
  int substeps() const { return substeps_; }

 private:
  UnicycleParameters parameters_;
  double dt_s_;
  int substeps_;
};

}  // namespace excite::sim

#endif  // EXCITE_SIM_PLANTS_UNICYCLE_H_
