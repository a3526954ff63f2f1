#include "sim/plants/duffing.h"

namespace excite::sim {

Duffing::Duffing(const DuffingParameters& parameters, double dt_s, int substeps)
    : Rk4Plant(dt_s, substeps), p_(parameters) {}

Eigen::VectorXd Duffing::Derivative(const Eigen::VectorXd& x,
                                    const Eigen::VectorXd& u) const {
  const double position = x(0), speed = x(1);
  Eigen::VectorXd dx(2);
  dx << speed, u(0) - p_.damping * speed - p_.linear_stiffness * position -
                   p_.cubic_stiffness * position * position * position;
  return dx;
}

double Duffing::Energy(const Eigen::VectorXd& x) const {
  const double x2 = x(0) * x(0);
  return 0.5 * x(1) * x(1) + 0.5 * p_.linear_stiffness * x2 +
         0.25 * p_.cubic_stiffness * x2 * x2;
}

}  // namespace excite::sim
