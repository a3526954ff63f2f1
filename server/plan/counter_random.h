#ifndef EXCITE_SERVER_PLAN_COUNTER_RANDOM_H_
#define EXCITE_SERVER_PLAN_COUNTER_RANDOM_H_

#include <cstdint>

namespace excite::plan {

// Counter-based pseudo-random numbers: a pure function of (seed, stream, dimension,
// index), so a signal's value at sample k can be computed without replaying
// samples 0..k-1 (a restarted session continues the same signal). The words are
// combined with SplitMix64's finaliser (Steele, Lea and Flood, "Fast splittable
// pseudorandom number generators", 2014) applied after each word. The same on
// every platform.
uint64_t CounterBits(uint64_t seed, uint64_t stream, uint64_t dimension, uint64_t index);

// Uniform in [0, 1) from the top 53 bits of CounterBits.
double CounterUniform(uint64_t seed, uint64_t stream, uint64_t dimension, uint64_t index);

// Streams used by the signals (distinct, so prbs and random differ for one seed).
inline constexpr uint64_t kPrbsStream = 0x70726273;    // "prbs"
inline constexpr uint64_t kRandomStream = 0x72616e64;  // "rand"

}  // namespace excite::plan

#endif  // EXCITE_SERVER_PLAN_COUNTER_RANDOM_H_
