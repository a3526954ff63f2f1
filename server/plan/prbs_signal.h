#ifndef EXCITE_SERVER_PLAN_PRBS_SIGNAL_H_
#define EXCITE_SERVER_PLAN_PRBS_SIGNAL_H_

#include <Eigen/Dense>
#include <cstdint>

namespace excite::plan {

// A pseudo-random binary sequence (PRBS) between the input bounds, per input
// dimension: time is cut into clock periods of `min_hold` samples, aligned at
// sample 0, and in each period input j sits at lower(j) or upper(j) by a fair
// pseudo-random bit, CounterBits(seed, kPrbsStream, j, k / min_hold) (top bit). So
// every run between two switches lasts a multiple of min_hold samples, and the
// value at sample k is a pure function of (seed, k): no state, a restart continues
// the sequence. (A random binary signal with a clock period, not a maximum-length
// LFSR sequence: those need the previous bits, and their period matters only for
// correlation analysis, not for exploration.)
//
// Returns the inputs at samples first_index .. first_index + count - 1
// (count x lower.size()). Requires min_hold >= 1, first_index >= 0, count >= 0,
// lower.size() == upper.size().
Eigen::MatrixXd PrbsSignal(const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
                           int min_hold, uint64_t seed, int64_t first_index, int count);

}  // namespace excite::plan

#endif  // EXCITE_SERVER_PLAN_PRBS_SIGNAL_H_
