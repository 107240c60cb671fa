// Sliced device work (run_sliced): slices cover the index space once, in order, in granules; they grow
// toward kSliceSeconds when the work is quick and shrink when it is slow, by the granules' estimated costs;
// a cancel stops the work between two slices; a slice of a 2D grid of tiles is a few rectangles. The
// Watchdog that bounds a shutdown ends the process when it is not disarmed in time.
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

// Runs `plan` with a device time of seconds_per_cost times each slice's cost.
Slices record(const SlicePlan& plan, double seconds_per_cost = 0, std::vector<double>* seconds = nullptr) {
  Slices slices;
  QueueLease lease;
  run_sliced(test::runtime(), lease, plan, {}, "test work", [&](size_t first, size_t count) {
    slices.emplace_back(first, count);
    double cost = 0;
    for (size_t g = first / plan.granule; g < (first + count) / plan.granule; ++g) cost += plan.cost(g);
    std::this_thread::sleep_for(std::chrono::duration<double>(seconds_per_cost * cost));
    if (seconds) seconds->push_back(seconds_per_cost * cost);
  });
  return slices;
}

SlicePlan uniform(size_t granules, size_t granule, double first_cost) {
  SlicePlan plan;
  plan.granules = granules;
  plan.granule = granule;
  plan.first_cost = first_cost;
  return plan;
}

TEST(Slices, CoverTheIndexSpaceOnceInOrderInGranules) {
  const Slices slices = record(uniform(1000, 8, 2.5));
  size_t next = 0;
  for (const auto& [first, count] : slices) {
    EXPECT_EQ(first, next);
    EXPECT_EQ(count % 8, 0u);
    EXPECT_GT(count, 0u);
    next = first + count;
  }
  EXPECT_EQ(next, 8000u);
  EXPECT_EQ(slices.front().second, 16u) << "the first slice: whole granules within its cost";
}

TEST(Slices, QuickWorkGrowsFourfoldASliceUpToTheWhole) {
  const Slices slices = record(uniform(1 << 20, 1, 1));
  ASSERT_GE(slices.size(), 3u);
  EXPECT_EQ(slices[1].second, 4u);
  EXPECT_EQ(slices[2].second, 16u);
  EXPECT_LT(slices.size(), 12u) << "2^20 ids in at most about log4(2^20) slices";
}

// 1 ms per id: a slice of 100 ids is kSliceSeconds. Starting from 400 (0.4 s) the slices shrink to it (or
// below, where a loaded machine stretches the sleeps that stand for the work).
TEST(Slices, SlowWorkShrinksTowardTheTargetTime) {
  const Slices slices = record(uniform(1000, 1, 400), 1e-3);
  ASSERT_GE(slices.size(), 3u);
  EXPECT_EQ(slices[0].second, 400u);
  EXPECT_EQ(slices[1].second, 100u);
  EXPECT_LE(slices[2].second, 102u);
  EXPECT_GE(slices[2].second, 50u);
}

TEST(Slices, ACancelStopsTheWorkBetweenTwoSlices) {
  int calls = 0;
  Cancellation cancel([&] { return calls >= 2; });
  test::expect_error(Code::Cancelled, "test work cancelled", [&] {
    QueueLease lease;
    run_sliced(test::runtime(), lease, uniform(100, 1, 1), cancel, "test work", [&](size_t, size_t) { ++calls; });
  });
  EXPECT_EQ(calls, 2);
}

// Quick slices share one lease of a device queue, still held at the end for the caller's read-back; slices
// of kSliceSeconds each take the queue anew, so other requests' work goes in between.
TEST(Slices, AShortJobTakesTheDeviceOnceALongOneLetsOthersIn) {
  Runtime& runtime = test::runtime();
  const uint64_t before = runtime.device_wait().acquisitions;
  QueueLease lease;
  const size_t quick = run_sliced(runtime, lease, uniform(1 << 12, 1, 1), {}, "test work", [](size_t, size_t) {});
  EXPECT_GE(quick, 3u);
  EXPECT_TRUE(lease.held());
  EXPECT_EQ(held_queue_slot(), int(lease.slot()));
  lease.unlock();
  // once (twice where the machine paused the test past a slice's time between two of them), not per slice
  EXPECT_LE(runtime.device_wait().acquisitions - before, 2u) << quick << " quick slices";

  const uint64_t middle = runtime.device_wait().acquisitions;
  const Slices slow = record(uniform(300, 1, 100), 1e-3);  // 0.1 s a slice
  EXPECT_EQ(runtime.device_wait().acquisitions - middle, slow.size());
}

// 2000 cheap granules (a ray that misses the cloud: 10 us) then 500 costly ones (1 ms): sized by count, the
// slices grow on the cheap ones to thousands and the first costly slice holds the device for seconds;
// sized by cost, no slice takes much more than kSliceSeconds.
TEST(Slices, CostlyGranulesAfterCheapOnesKeepTheSliceTime) {
  SlicePlan plan = uniform(2500, 1, 10);
  plan.cost = [](size_t g) { return g < 2000 ? 0.01 : 1.0; };
  std::vector<double> seconds;
  const Slices slices = record(plan, 1e-3, &seconds);
  EXPECT_EQ(slices.back().first + slices.back().second, 2500u);
  for (size_t i = 0; i < slices.size(); ++i)
    EXPECT_LE(seconds[i], 2 * kSliceSeconds)
        << "slice " << i << ": " << slices[i].second << " granules from " << slices[i].first;
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
