// Sliced device work (run_sliced): slices cover the index space once, in order, in granules; they grow
// toward kSliceSeconds when the work is quick and shrink when it is slow; a cancel stops the work between
// two slices; a slice of a 2D grid of tiles is a few rectangles. The Watchdog that bounds a shutdown ends the process when it is not disarmed in time.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>
#include <utility>
#include <vector>

#include "common/watchdog.h"
#include "runtime/slices.h"
#include "support/expect_error.h"
#include "support/test_runtime.h"

namespace squall {
namespace {

using Slices = std::vector<std::pair<size_t, size_t>>;

Slices record(const SlicePlan& plan, double seconds_per_id = 0, const Cancellation& cancel = {}) {
  Slices slices;
  run_sliced(test::runtime(), plan, cancel, "test work", [&](size_t first, size_t count) {
    slices.emplace_back(first, count);
    std::this_thread::sleep_for(std::chrono::duration<double>(seconds_per_id * double(count)));
  });
  return slices;
}

TEST(Slices, CoverTheIndexSpaceOnceInOrderInGranules) {
  const Slices slices = record({8 * 1000, 8, 20});
  size_t next = 0;
  for (const auto& [first, count] : slices) {
    EXPECT_EQ(first, next);
    EXPECT_EQ(count % 8, 0u);
    EXPECT_GT(count, 0u);
    next = first + count;
  }
  EXPECT_EQ(next, 8000u);
  EXPECT_EQ(slices.front().second, 16u) << "the first slice is rounded down to granules";
}

TEST(Slices, QuickWorkGrowsFourfoldASliceUpToTheWhole) {
  const Slices slices = record({1 << 20, 1, 1});
  ASSERT_GE(slices.size(), 3u);
  EXPECT_EQ(slices[1].second, 4u);
  EXPECT_EQ(slices[2].second, 16u);
  EXPECT_LT(slices.size(), 12u) << "2^20 ids in at most about log4(2^20) slices";
}

// 1 ms per id: a slice of 100 ids is kSliceSeconds. Starting from 400 (0.4 s) the slices shrink to it.
TEST(Slices, SlowWorkShrinksTowardTheTargetTime) {
  const Slices slices = record({1000, 1, 400}, 1e-3);
  ASSERT_GE(slices.size(), 3u);
  EXPECT_EQ(slices[0].second, 400u);
  EXPECT_EQ(slices[1].second, 100u);
  EXPECT_NEAR(double(slices[2].second), 100.0, 20.0);
}

TEST(Slices, ACancelStopsTheWorkBetweenTwoSlices) {
  int calls = 0;
  Cancellation cancel([&] { return calls >= 2; });
  test::expect_error(Code::Cancelled, "test work cancelled", [&] {
    run_sliced(test::runtime(), {100, 1, 1}, cancel, "test work", [&](size_t, size_t) { ++calls; });
  });
  EXPECT_EQ(calls, 2);
}

// Every slice of a 5 x 4 grid of tiles, as rectangles, covers exactly its tiles.
TEST(TileGrid, ASliceIsAtMostThreeRectanglesCoveringExactlyItsTiles) {
  const TileGrid grid{5, 4};
  for (size_t first = 0; first < 20; ++first)
    for (size_t count = 1; first + count <= 20; ++count) {
      std::vector<int> covered(20, 0);
      const auto rectangles = grid.rectangles(first, count);
      EXPECT_LE(rectangles.size(), 3u);
      for (const auto& r : rectangles)
        for (size_t y = r.y; y < r.y + r.height; ++y)
          for (size_t x = r.x; x < r.x + r.width; ++x) ++covered[y * 5 + x];
      for (size_t t = 0; t < 20; ++t)
        EXPECT_EQ(covered[t], t >= first && t < first + count ? 1 : 0) << first << " + " << count << ", tile " << t;
    }
}

TEST(Watchdog, DisarmedInTimeItDoesNothing) {
  { Watchdog watchdog(std::chrono::milliseconds(200), 4, "overran"); }
  std::this_thread::sleep_for(std::chrono::milliseconds(400));
  SUCCEED();
}

TEST(WatchdogDeathTest, NotDisarmedItEndsTheProcessWithItsCode) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(
      {
        Watchdog watchdog(std::chrono::milliseconds(200), 4, "a call overran");
        std::this_thread::sleep_for(std::chrono::seconds(30));
      },
      testing::ExitedWithCode(4), "a call overran");
}

}  // namespace
}  // namespace squall
