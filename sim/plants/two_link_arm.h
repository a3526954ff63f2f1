#ifndef EXCITE_SIM_PLANTS_TWO_LINK_ARM_H_
#define EXCITE_SIM_PLANTS_TWO_LINK_ARM_H_

#include <Eigen/Dense>
#include <string>

#include "sim/plants/plant.h"

namespace excite::sim {

// Physical parameters of a planar two-link arm in a vertical plane (SI). Each link is
// a uniform rod: centre of mass at half its length, inertia m a^2 / 12 about it.
struct TwoLinkArmParameters {
  double mass1_kg = 1.0;
  double mass2_kg = 1.0;
  double length1_m = 1.0;
  double length2_m = 1.0;
  double damping1 = 0.5;  // d1, N m s / rad.
  double damping2 = 0.5;  // d2, N m s / rad.
  double gravity = 9.81;  // g, m / s^2.
};

// Rigid-body manipulator dynamics (Siciliano et al., "Robotics", Section 7.3.2)
//   M(q) q'' + C(q, q') q' + g(q) + D q' = tau,   D = diag(d1, d2).
// State x = (q1, q2, q1', q2') [rad, rad/s]: q1 is link 1's angle from the downward
// vertical, q2 link 2's angle relative to link 1 (x = 0: hanging straight down at
// rest, the stable equilibrium); angles are not wrapped. Input u = (tau1, tau2)
// [N m], held over one sampling period dt, integrated with `substeps` RK4 steps.
// The factory checks the parameters (plant_factory.h). Thread-safe.
class TwoLinkArm : public Plant {
 public:
  TwoLinkArm(const TwoLinkArmParameters& parameters, double dt_s, int substeps);

  std::string name() const override { return "two_link"; }
  int state_dim() const override { return 4; }
  int input_dim() const override { return 2; }
  Eigen::VectorXd Step(const Eigen::VectorXd& x, const Eigen::VectorXd& u) const override;

  // The inertia matrix M(q) [kg m^2]; depends on q2 only.
  Eigen::Matrix2d MassMatrix(double q2) const;
  // Coriolis and centrifugal torques C(q, q') q' [N m].
  Eigen::Vector2d CoriolisTorques(const Eigen::Vector2d& q,
                                  const Eigen::Vector2d& q_dot) const;
  // Gravity torques g(q) = dV/dq [N m].
  Eigen::Vector2d GravityTorques(const Eigen::Vector2d& q) const;
  // The continuous-time vector field (q', q'') at x = (q, q') under torques tau.
  Eigen::Vector4d Derivative(const Eigen::Vector4d& x, const Eigen::Vector2d& tau) const;
  // Kinetic energy q'^T M(q) q' / 2 plus potential energy, 0 hanging at rest [J].
  double Energy(const Eigen::Vector4d& x) const;

  const TwoLinkArmParameters& parameters() const { return parameters_; }
  double dt_s() const { return dt_s_; }
  int substeps() const { return substeps_; }

 private:
  TwoLinkArmParameters parameters_;
  double dt_s_;
  int substeps_;
};

}  // namespace excite::sim

#endif  // EXCITE_SIM_PLANTS_TWO_LINK_ARM_H_
