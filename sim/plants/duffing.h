#ifndef EXCITE_SIM_PLANTS_DUFFING_H_
#define EXCITE_SIM_PLANTS_DUFFING_H_

#include <Eigen/Dense>
#include <string>

#include "sim/plants/rk4_plant.h"

namespace excite::sim {

// The double well of client/python/examples/duffing.py.
struct DuffingParameters {
  double damping = 0.3;
  double linear_stiffness = -1.0;
  double cubic_stiffness = 1.0;
};

// The forced Duffing oscillator x'' + delta x' + alpha x + beta x^3 = u (Kovacic and
// Brennan 2011). State (x, x'); input u, the forcing.
class Duffing : public Rk4Plant {
 public:
  Duffing(const DuffingParameters& parameters, double dt_s, int substeps);

  std::string name() const override { return "duffing"; }
  int state_dim() const override { return 2; }
  int input_dim() const override { return 1; }
  Eigen::VectorXd Derivative(const Eigen::VectorXd& x,
                             const Eigen::VectorXd& u) const override;
  // x'^2 / 2 + alpha x^2 / 2 + beta x^4 / 4; conserved without damping and force.
  double Energy(const Eigen::VectorXd& x) const;

 private:
  DuffingParameters p_;
};

}  // namespace excite::sim

#endif  // EXCITE_SIM_PLANTS_DUFFING_H_
