// A hash for tables keyed by values a client chooses (vertex indices, positions, node coordinates): the
// splitmix64 finalizer (G. L. Steele, D. Lea, C. H. Flood, "Fast splittable pseudorandom number
// generators", OOPSLA 2014, the mix of SplitMix64) of the key folded with a seed drawn once per process.
// std::hash<uint64_t> is the identity in libstdc++, so keys a client picks congruent modulo the table's
// (predictable, prime) bucket count all land in one bucket and every lookup walks them; a client that does
// not know the seed cannot aim keys at one bucket.
#pragma once

#include <cstddef>
#include <cstdint>
#include <random>

namespace squall {

// The seed of this process's SeededHash, drawn from std::random_device at its first use.
inline uint64_t hash_seed() {
  static const uint64_t seed = [] {
    std::random_device device;
    return uint64_t(device()) << 32 ^ device();
  }();
  return seed;
}

// h folded with v: the splitmix64 finalizer of h + v (a bijection of 64 bits).
inline uint64_t mix_in(uint64_t h, uint64_t v) {
  uint64_t z = h + v + 0x9e3779b97f4a7c15ull;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

struct SeededHash {
  size_t operator()(uint64_t key) const { return size_t(mix_in(hash_seed(), key)); }
};

}  // namespace squall
