// 64-bit FNV-1a (G. Fowler, L. C. Noll, K.-P. Vo, D. Eastlake, "The FNV Non-Cryptographic Hash Algorithm",
// IETF draft-eastlake-fnv): a fingerprint of bytes for cache keys and checkpoints. Not a defence against a
// forger, who can make any bytes; what reads a fingerprinted state still checks it in full.
#pragma once

#include <cstddef>
#include <cstdint>

namespace squall {

constexpr uint64_t kFnv1aOffsetBasis = 14695981039346656037ull;

// h folded with `bytes` bytes at `data`; start a fingerprint from kFnv1aOffsetBasis.
inline uint64_t fnv1a(uint64_t h, const void* data, size_t bytes) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (size_t k = 0; k < bytes; ++k) h = (h ^ p[k]) * 1099511628211ull;
  return h;
}

}  // namespace squall
