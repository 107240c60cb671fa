// A counter-based random number generator: every draw is a pure function of (seed, stream, counter), so a
// run is reproducible on any device and in any order of evaluation. The mixing function is SplitMix64
// (G. Steele, D. Lea, C. Flood, "Fast Splittable Pseudorandom Number Generators", OOPSLA 2014), applied
// to a combination of the three keys.
#pragma once

#include <cstdint>

namespace squall::textures {

// What a draw is for, so that two purposes never share a sequence.
enum class RngPurpose : uint64_t { PoissonSeed = 1, PoissonAngle = 2, PatchOrigin = 3, RegenerationOffset = 4 };

inline uint64_t splitmix64(uint64_t z) {
  z += 0x9e3779b97f4a7c15ull;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

class CounterRng {
 public:
  CounterRng(uint64_t seed, RngPurpose purpose) : key_(splitmix64(seed ^ splitmix64(uint64_t(purpose)))) {}

  // The 64 random bits of draw `counter`.
  uint64_t bits(uint64_t counter) const { return splitmix64(key_ ^ splitmix64(counter + 0x632be59bd9b4e019ull)); }
  // A double uniform in [0, 1) (53 bits).
  double uniform(uint64_t counter) const { return double(bits(counter) >> 11) * 0x1.0p-53; }

 private:
  uint64_t key_;
};

}  // namespace squall::textures
