// SeededHash, for tables keyed by values a client chooses: keys aimed at one bucket of std::hash (the
// identity in libstdc++) spread over the table.
#include "common/seeded_hash.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <functional>
#include <unordered_set>

namespace squall {
namespace {

// The most keys any one bucket of `table` holds.
template <typename Table>
size_t fullest_bucket(const Table& table) {
  size_t most = 0;
  for (size_t b = 0; b < table.bucket_count(); ++b) most = std::max(most, table.bucket_size(b));
  return most;
}

// 20 000 multiples of the bucket count a table reserved for them has: with std::hash every one lands in
// bucket 0 (each lookup walks them all); with SeededHash the fullest bucket holds a handful, as for random
// keys (about ln n / ln ln n: 5 or so, under 16 at any seed).
template <typename Hash>
size_t fullest_bucket_of_aimed_keys() {
  constexpr size_t kKeys = 20000;
  std::unordered_set<uint64_t, Hash> table;
  table.reserve(kKeys);
  const uint64_t stride = table.bucket_count();
  for (uint64_t k = 1; k <= kKeys; ++k) table.insert(k * stride);
  EXPECT_EQ(table.bucket_count(), stride) << "the table grew: the keys were not aimed at its buckets";
  return fullest_bucket(table);
}

TEST(SeededHash, KeysAimedAtOneBucketOfTheIdentityHashSpread) {
  EXPECT_EQ(fullest_bucket_of_aimed_keys<std::hash<uint64_t>>(), 20000u) << "std::hash is no longer the identity";
  EXPECT_LT(fullest_bucket_of_aimed_keys<SeededHash>(), 16u);
}

}  // namespace
}  // namespace squall
