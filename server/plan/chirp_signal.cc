#include "server/plan/chirp_signal.h"

#include <algorithm>
#include <cmath>

namespace excite::plan {
namespace {

constexpr double kTwoPi = 6.283185307179586;

}  // namespace

double ChirpPhase(const ChirpParams& params, int64_t k) {
  const int64_t period = std::max(params.period, 1);
  const double tau = static_cast<double>(k % period);
  const double f0 = params.start_frequency;
  const double f1 = params.end_frequency;
  return kTwoPi *
         (f0 * tau + (f1 - f0) * tau * tau / (2.0 * static_cast<double>(period)));
}

double ChirpFrequency(const ChirpParams& params, double tau) {
  const double period = static_cast<double>(std::max(params.period, 1));
  return params.start_frequency +
         (params.end_frequency - params.start_frequency) * tau / period;
}

Eigen::MatrixXd ChirpSignal(const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
                            const ChirpParams& params, int64_t first_index, int count) {
  const int du = static_cast<int>(lower.size());
  Eigen::MatrixXd inputs(std::max(count, 0), du);
  for (int i = 0; i < inputs.rows(); ++i) {
    const double phase = ChirpPhase(params, first_index + i);
    for (int j = 0; j < du; ++j) {
      const double centre = 0.5 * (lower(j) + upper(j));
      const double half_width = 0.5 * (upper(j) - lower(j));
      const double value =
          centre + half_width * std::sin(phase + kTwoPi * j / static_cast<double>(du));
      // Rounding must not leave the box.
      inputs(i, j) = std::clamp(value, lower(j), upper(j));
    }
  }
  return inputs;
}

}  // namespace excite::plan
