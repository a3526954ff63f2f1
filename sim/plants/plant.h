#ifndef EXCITE_SIM_PLANTS_PLANT_H_
#define EXCITE_SIM_PLANTS_PLANT_H_

#include <Eigen/Dense>
#include <string>
#include <utility>
#include <vector>

namespace excite::sim {

// A deterministic discrete-time plant x_{k+1} = f(x_k, u_k) over one sampling
// period. Plants know nothing of GPs or of the server; measurement noise is added
// by the simulation client, not here. Step() is const and thread-safe.
class Plant {
 public:
  virtual ~Plant() = default;
  virtual std::string name() const = 0;
  virtual int state_dim() const = 0;
  virtual int input_dim() const = 0;
  // The true next state after applying u (held constant) for one sampling period.
  // u is used as given: bounds are the caller's business.
  virtual Eigen::VectorXd Step(const Eigen::VectorXd& x,
                               const Eigen::VectorXd& u) const = 0;
  // State dimensions that hold one angle as (sin, cos): (sin index, cos index)
  // pairs. A state the plant can be in has sin^2 + cos^2 = 1 in each; tools that
  // draw states (the evaluation set) draw the angle, not the two numbers.
  virtual std::vector<std::pair<int, int>> AnglePairs() const { return {}; }
};

}  // namespace excite::sim

#endif  // EXCITE_SIM_PLANTS_PLANT_H_
