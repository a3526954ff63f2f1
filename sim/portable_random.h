#ifndef EXCITE_SIM_PORTABLE_RANDOM_H_
#define EXCITE_SIM_PORTABLE_RANDOM_H_

#include <cmath>
#include <cstdint>
#include <random>

namespace excite::sim {

// Seeded random numbers that are the same on every platform and standard library:
// std::mt19937_64's sequence is fixed by the standard, but std::*_distribution are
// implementation-defined, so the conversions are done here. Not thread-safe.
class PortableRandom {
 public:
  // `stream` separates independent sequences drawn from one user seed (noise,
  // initial inputs, evaluation points, ...).
  explicit PortableRandom(uint64_t seed, uint64_t stream = 0)
      : engine_(seed ^ (stream * 0x9E3779B97F4A7C15ULL)) {}

  // Uniform on [0, 1) with 53 random bits.
  double Uniform01() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  // Uniform on [lower, upper).
  double Uniform(double lower, double upper) {
    return lower + (upper - lower) * Uniform01();
  }
  // Standard normal (Box-Muller; one draw per call, the pair's twin is discarded).
  double Normal() {
    const double u1 = 1.0 - Uniform01();  // (0, 1]: log is finite.
    const double u2 = Uniform01();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
  }

 private:
  static constexpr double kPi = 3.14159265358979323846;
  std::mt19937_64 engine_;
};

}  // namespace excite::sim

#endif  // EXCITE_SIM_PORTABLE_RANDOM_H_
