#include "server/plan/random_signal.h"

#include <algorithm>

#include "server/plan/counter_random.h"

namespace excite::plan {

Eigen::MatrixXd RandomSignal(const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
                             int hold, uint64_t seed, int64_t first_index, int count) {
  const int du = static_cast<int>(lower.size());
  const int64_t h = std::max(hold, 1);
  Eigen::MatrixXd inputs(std::max(count, 0), du);
  for (int i = 0; i < inputs.rows(); ++i) {
    const uint64_t block = static_cast<uint64_t>((first_index + i) / h);
    for (int j = 0; j < du; ++j) {
      const double r =
          CounterUniform(seed, kRandomStream, static_cast<uint64_t>(j), block);
      inputs(i, j) = std::min(lower(j) + (upper(j) - lower(j)) * r, upper(j));
    }
  }
  return inputs;
}

}  // namespace excite::plan
