#ifndef EXCITE_SERVER_GP_HYPERPARAMETERS_H_
#define EXCITE_SERVER_GP_HYPERPARAMETERS_H_

#include <Eigen/Dense>

namespace excite::gp {

// Hyperparameters of one GP with a squared-exponential ARD kernel
// k(a, b) = signal_variance * exp(-0.5 * sum_l ((a_l - b_l) / lengthscales_l)^2)
// and Gaussian noise of variance noise_variance on the target.
struct Hyperparameters {
  double signal_variance = 1.0;
  Eigen::VectorXd lengthscales;
  double noise_variance = 1e-2;
};

}  // namespace excite::gp

#endif  // EXCITE_SERVER_GP_HYPERPARAMETERS_H_
