#include "sim/plants/cart_pole.h"

#include <cmath>

namespace excite::sim {

CartPole::CartPole(const CartPoleParameters& parameters, double dt_s, int substeps)
    : Rk4Plant(dt_s, substeps), p_(parameters) {}

Eigen::VectorXd CartPole::Derivative(const Eigen::VectorXd& x,
                                     const Eigen::VectorXd& u) const {
  const double theta = x(1), v = x(2), w = x(3);
  const double mp = p_.pole_mass_kg, l = p_.pole_half_length_m;
  const double total = p_.cart_mass_kg + mp;
  const double s = std::sin(theta), c = std::cos(theta);
  const double push = (u(0) + mp * l * w * w * s) / total;
  const double angular =
      (p_.gravity * s - c * push) / (l * (4.0 / 3.0 - mp * c * c / total));
  const double linear = push - mp * l * angular * c / total;
  Eigen::VectorXd dx(4);
  dx << v, w, linear, angular;
  return dx;
}

double CartPole::Energy(const Eigen::VectorXd& x) const {
  const double theta = x(1), v = x(2), w = x(3);
  const double mp = p_.pole_mass_kg, l = p_.pole_half_length_m;
  const double total = p_.cart_mass_kg + mp;
  const double kinetic = 0.5 * total * v * v + mp * l * std::cos(theta) * v * w +
                         0.5 * (4.0 / 3.0) * mp * l * l * w * w;
  return kinetic + mp * p_.gravity * l * std::cos(theta);
}

}  // namespace excite::sim
