#ifndef EXCITE_SIM_PLANTS_RK4_PLANT_H_
#define EXCITE_SIM_PLANTS_RK4_PLANT_H_

#include <Eigen/Dense>

#include "sim/plants/plant.h"
#include "sim/plants/rk4.h"

namespace excite::sim {

// A plant given by its continuous-time vector field x' = f(x, u): the input is
// held over the sampling period dt, integrated with `substeps` RK4 steps (the
// factory checks dt > 0 and substeps >= 1). Thread-safe if Derivative() is.
class Rk4Plant : public Plant {
 public:
  Rk4Plant(double dt_s, int substeps) : dt_s_(dt_s), substeps_(substeps) {}

  // f(x, u).
  virtual Eigen::VectorXd Derivative(const Eigen::VectorXd& x,
                                     const Eigen::VectorXd& u) const = 0;

  Eigen::VectorXd Step(const Eigen::VectorXd& x, const Eigen::VectorXd& u) const final {
    return Rk4Integrate([&](const Eigen::VectorXd& s) { return Derivative(s, u); }, x,
                        dt_s_, substeps_);
  }

  double dt_s() const { return dt_s_; }
  int substeps() const { return substeps_; }

 private:
  double dt_s_;
  int substeps_;
};

}  // namespace excite::sim

#endif  // EXCITE_SIM_PLANTS_RK4_PLANT_H_
