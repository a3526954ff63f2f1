#include "server/plan/prbs_signal.h"

#include <algorithm>

#include "server/plan/counter_random.h"

namespace excite::plan {

Eigen::MatrixXd PrbsSignal(const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
                           int min_hold, uint64_t seed, int64_t first_index, int count) {
  const int du = static_cast<int>(lower.size());
  const int64_t hold = std::max(min_hold, 1);
  Eigen::MatrixXd inputs(std::max(count, 0), du);
  for (int i = 0; i < inputs.rows(); ++i) {
    const uint64_t block = static_cast<uint64_t>((first_index + i) / hold);
    for (int j = 0; j < du; ++j) {
      const bool high =
          (CounterBits(seed, kPrbsStream, static_cast<uint64_t>(j), block) >> 63) != 0;
      inputs(i, j) = high ? upper(j) : lower(j);
    }
  }
  return inputs;
}

}  // namespace excite::plan
