#include "server/plan/reference_set.h"

#include <cmath>

#include "server/plan/counter_random.h"

namespace excite::plan {
namespace {

constexpr uint64_t kReferenceStream = 0x726f6921;  // "roi!"

// The first 64 primes: Halton bases.
constexpr int kPrimes[64] = {
    2,   3,   5,   7,   11,  13,  17,  19,  23,  29,  31,  37,  41,  43,  47,  53,
    59,  61,  67,  71,  73,  79,  83,  89,  97,  101, 103, 107, 109, 113, 127, 131,
    137, 139, 149, 151, 157, 163, 167, 173, 179, 181, 191, 193, 197, 199, 211, 223,
    227, 229, 233, 239, 241, 251, 257, 263, 269, 271, 277, 281, 283, 293, 307, 311};

// Radical inverse of i in base b: the digits of i mirrored after the point.
double RadicalInverse(uint64_t i, int base) {
  double result = 0.0;
  double digit_value = 1.0 / base;
  while (i > 0) {
    result += static_cast<double>(i % static_cast<uint64_t>(base)) * digit_value;
    i /= static_cast<uint64_t>(base);
    digit_value /= base;
  }
  return result;
}

}  // namespace

Eigen::MatrixXd HaltonReferenceSet(const Eigen::VectorXd& lower,
                                   const Eigen::VectorXd& upper, int count,
                                   uint64_t seed) {
  const Eigen::Index dim = lower.size();
  Eigen::MatrixXd points(count, dim);
  for (Eigen::Index l = 0; l < dim; ++l) {
    const int base = kPrimes[l % 64];
    const double shift = CounterUniform(seed, kReferenceStream, l, 0);
    for (int i = 0; i < count; ++i) {
      // Index from 1: the point 0 of every Halton sequence is the corner.
      double u = RadicalInverse(static_cast<uint64_t>(i) + 1, base) + shift;
      u -= std::floor(u);
      points(i, l) = lower(l) + (upper(l) - lower(l)) * u;
    }
  }
  return points;
}

}  // namespace excite::plan
