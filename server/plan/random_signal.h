#ifndef EXCITE_SERVER_PLAN_RANDOM_SIGNAL_H_
#define EXCITE_SERVER_PLAN_RANDOM_SIGNAL_H_

#include <Eigen/Dense>
#include <cstdint>

namespace excite::plan {

// Uniformly random inputs held for `hold` samples (the paper's further baseline,
// Section 6): input j during the hold period b = k / hold (aligned at sample 0) is
//   lower(j) + (upper(j) - lower(j)) CounterUniform(seed, kRandomStream, j, b),
// a pure function of (seed, k). Returns the inputs at samples first_index ..
// first_index + count - 1 (count x lower.size()). Requires hold >= 1.
Eigen::MatrixXd RandomSignal(const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
                             int hold, uint64_t seed, int64_t first_index, int count);

}  // namespace excite::plan

#endif  // EXCITE_SERVER_PLAN_RANDOM_SIGNAL_H_
