#include "sim/plants/acrobot.h"

#include <cmath>

namespace excite::sim {

Acrobot::Acrobot(const AcrobotParameters& parameters, double dt_s, int substeps)
    : Rk4Plant(dt_s, substeps), p_(parameters) {}

Eigen::Matrix2d Acrobot::MassMatrix(double q2) const {
  const double m1 = p_.mass1_kg, m2 = p_.mass2_kg, l1 = p_.length1_m;
  const double lc1 = p_.com1_m, lc2 = p_.com2_m;
  const double d1 = m1 * lc1 * lc1 +
                    m2 * (l1 * l1 + lc2 * lc2 + 2 * l1 * lc2 * std::cos(q2)) +
                    p_.inertia1 + p_.inertia2;
  const double d2 = m2 * (lc2 * lc2 + l1 * lc2 * std::cos(q2)) + p_.inertia2;
  Eigen::Matrix2d mass;
  mass << d1, d2, d2, m2 * lc2 * lc2 + p_.inertia2;
  return mass;
}

Eigen::VectorXd Acrobot::Derivative(const Eigen::VectorXd& x,
                                    const Eigen::VectorXd& u) const {
  const double q1 = x(0), q2 = x(1), w1 = x(2), w2 = x(3);
  const double m1 = p_.mass1_kg, m2 = p_.mass2_kg, l1 = p_.length1_m;
  const double lc1 = p_.com1_m, lc2 = p_.com2_m, g = p_.gravity;
  const Eigen::Matrix2d mass = MassMatrix(q2);
  const double d1 = mass(0, 0), d2 = mass(0, 1), d22 = mass(1, 1);
  // Gravity and velocity terms (Sutton and Barto's phi1, phi2; their
  // cos(q - pi/2) written as sin q).
  const double phi2 = m2 * lc2 * g * std::sin(q1 + q2);
  const double phi1 = -m2 * l1 * lc2 * w2 * w2 * std::sin(q2) -
                      2 * m2 * l1 * lc2 * w2 * w1 * std::sin(q2) +
                      (m1 * lc1 + m2 * l1) * g * std::sin(q1) + phi2;
  const double a2 =
      (u(0) + d2 / d1 * phi1 - m2 * l1 * lc2 * w1 * w1 * std::sin(q2) - phi2) /
      (d22 - d2 * d2 / d1);
  const double a1 = -(d2 * a2 + phi1) / d1;
  Eigen::VectorXd dx(4);
  dx << w1, w2, a1, a2;
  return dx;
}

double Acrobot::Energy(const Eigen::VectorXd& x) const {
  const double q1 = x(0), q2 = x(1);
  const Eigen::Vector2d w = x.tail<2>();
  const double kinetic = 0.5 * w.dot(MassMatrix(q2) * w);
  const double potential = -(p_.mass1_kg * p_.com1_m + p_.mass2_kg * p_.length1_m) *
                               p_.gravity * std::cos(q1) -
                           p_.mass2_kg * p_.com2_m * p_.gravity * std::cos(q1 + q2);
  return kinetic + potential;
}

}  // namespace excite::sim
