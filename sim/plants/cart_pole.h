#ifndef EXCITE_SIM_PLANTS_CART_POLE_H_
#define EXCITE_SIM_PLANTS_CART_POLE_H_

#include <Eigen/Dense>
#include <string>

#include "sim/plants/rk4_plant.h"

namespace excite::sim {

// Barto, Sutton and Anderson's parameters (1983).
struct CartPoleParameters {
  double cart_mass_kg = 1.0;
  double pole_mass_kg = 0.1;
  double pole_half_length_m = 0.5;
  double gravity = 9.8;
};

// The cart-pole (Barto, Sutton and Anderson 1983; equations corrected by Florian
// 2007), frictionless, a uniform pole (inertia m_p l^2 / 3 about its centre). State
// x = (cart position [m], pole angle theta [rad] from upright, not wrapped, their
// rates); input u = (horizontal force on the cart [N]). With M = m_c + m_p,
//   theta'' = (g sin theta - cos theta (u + m_p l theta'^2 sin theta) / M)
//             / (l (4/3 - m_p cos^2 theta / M)),
//   x'' = (u + m_p l (theta'^2 sin theta - theta'' cos theta)) / M.
class CartPole : public Rk4Plant {
 public:
  CartPole(const CartPoleParameters& parameters, double dt_s, int substeps);

  std::string name() const override { return "cart_pole"; }
  int state_dim() const override { return 4; }
  int input_dim() const override { return 1; }
  Eigen::VectorXd Derivative(const Eigen::VectorXd& x,
                             const Eigen::VectorXd& u) const override;
  // Kinetic plus potential energy [J] (0 at the pivot's height); conserved
  // without force.
  double Energy(const Eigen::VectorXd& x) const;

 private:
  CartPoleParameters p_;
};

}  // namespace excite::sim

#endif  // EXCITE_SIM_PLANTS_CART_POLE_H_
