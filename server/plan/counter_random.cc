#include "server/plan/counter_random.h"

namespace excite::plan {
namespace {

// SplitMix64's output function: a bijective avalanche of 64 bits.
uint64_t Mix(uint64_t z) {
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

constexpr uint64_t kGolden = 0x9e3779b97f4a7c15ULL;

}  // namespace

uint64_t CounterBits(uint64_t seed, uint64_t stream, uint64_t dimension, uint64_t index) {
  uint64_t h = Mix(seed + kGolden);
  h = Mix(h ^ (stream + 2 * kGolden));
  h = Mix(h ^ (dimension + 3 * kGolden));
  return Mix(h ^ (index + 4 * kGolden));
}

double CounterUniform(uint64_t seed, uint64_t stream, uint64_t dimension,
                      uint64_t index) {
  return static_cast<double>(CounterBits(seed, stream, dimension, index) >> 11) *
         0x1.0p-53;
}

}  // namespace excite::plan
