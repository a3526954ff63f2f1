#ifndef EXCITE_SIM_PLANTS_ACROBOT_H_
#define EXCITE_SIM_PLANTS_ACROBOT_H_

#include <Eigen/Dense>
#include <string>

#include "sim/plants/rk4_plant.h"

namespace excite::sim {

// Sutton and Barto's parameters (1998, Section 11.3).
struct AcrobotParameters {
  double mass1_kg = 1.0;
  double mass2_kg = 1.0;
  double length1_m = 1.0;
  double com1_m = 0.5;
  double com2_m = 0.5;
  double inertia1 = 1.0;
  double inertia2 = 1.0;
  double gravity = 9.8;
};

// The acrobot (Spong 1995; Sutton and Barto 1998): a two-link pendulum with a
// torque at the elbow only, no friction. State x = (q1, q2, q1', q2') [rad, rad/s],
// q1 from the downward vertical, q2 relative to link 1, neither wrapped; input
// u = (elbow torque [N m]). Mass matrix M(q) = [[d1, d2], [d2, d22]] with
//   d1 = m1 lc1^2 + m2 (l1^2 + lc2^2 + 2 l1 lc2 cos q2) + I1 + I2,
//   d2 = m2 (lc2^2 + l1 lc2 cos q2) + I2,  d22 = m2 lc2^2 + I2,
// and potential energy V = -(m1 lc1 + m2 l1) g cos q1 - m2 lc2 g cos(q1 + q2).
class Acrobot : public Rk4Plant {
 public:
  Acrobot(const AcrobotParameters& parameters, double dt_s, int substeps);

  std::string name() const override { return "acrobot"; }
  int state_dim() const override { return 4; }
  int input_dim() const override { return 1; }
  Eigen::VectorXd Derivative(const Eigen::VectorXd& x,
                             const Eigen::VectorXd& u) const override;
  // Kinetic plus potential energy [J]; conserved without torque.
  double Energy(const Eigen::VectorXd& x) const;

 private:
  // M(q): [[d1, d2], [d2, d22]] (depends on q2 only).
  Eigen::Matrix2d MassMatrix(double q2) const;

  AcrobotParameters p_;
};

}  // namespace excite::sim

#endif  // EXCITE_SIM_PLANTS_ACROBOT_H_
