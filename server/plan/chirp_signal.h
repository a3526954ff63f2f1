#ifndef EXCITE_SERVER_PLAN_CHIRP_SIGNAL_H_
#define EXCITE_SERVER_PLAN_CHIRP_SIGNAL_H_

#include <Eigen/Dense>
#include <cstdint>

namespace excite::plan {

// A linear chirp: within each sweep of `period` samples the instantaneous
// frequency goes linearly from start_frequency to end_frequency (cycles per
// sample; a down-sweep if start > end), then the sweep starts again. With
// tau = k mod period and f0, f1 the start and end frequencies, the phase is
//   phi(k) = 2 pi (f0 tau + (f1 - f0) tau^2 / (2 period)),
// whose derivative in tau is 2 pi (f0 + (f1 - f0) tau / period).
struct ChirpParams {
  double start_frequency = 0.01;
  double end_frequency = 0.2;
  int period = 200;
};

// phi(k) above (radians). Requires period >= 1, k >= 0.
double ChirpPhase(const ChirpParams& params, int64_t k);

// The instantaneous frequency at position tau in [0, period) of a sweep.
double ChirpFrequency(const ChirpParams& params, double tau);

// Inputs at samples first_index .. first_index + count - 1 (count x du):
//   u_j(k) = c_j + a_j sin(phi(k) + 2 pi j / du),
// with c_j, a_j the centre and half-width of [lower(j), upper(j)]: the inputs
// stay within the bounds, and the phase offsets 2 pi j / du keep the dimensions
// from moving in lockstep. A pure function of k (a restart continues the signal).
Eigen::MatrixXd ChirpSignal(const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
                            const ChirpParams& params, int64_t first_index, int count);

}  // namespace excite::plan

#endif  // EXCITE_SERVER_PLAN_CHIRP_SIGNAL_H_
