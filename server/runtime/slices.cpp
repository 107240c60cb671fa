#include "runtime/slices.h"

#include <algorithm>
#include <chrono>

namespace squall {
namespace {

// The next slice's cost: the cost the last one would have needed to take kSliceSeconds at the rate it
// ran, changed by at most 4x (one odd timing does not swing it).
double next_cost(double budget, double cost, double seconds) {
  return std::clamp(cost / std::max(seconds, 1e-6) * kSliceSeconds, budget / 4, budget * 4);
}

}  // namespace

std::vector<TileGrid::Rect> TileGrid::rectangles(size_t first, size_t count) const {
  std::vector<Rect> out;
  const size_t end = first + count;
  if (first % x != 0) {  // the end of a row
    const size_t width = std::min(x - first % x, count);
    out.push_back({first % x, first / x, width, 1});
    first += width;
  }
  if (end - first >= x) {  // whole rows
    const size_t rows = (end - first) / x;
    out.push_back({0, first / x, x, rows});
    first += rows * x;
  }
  if (first < end) out.push_back({0, first / x, end - first, 1});  // the start of a row
  return out;
}

size_t run_sliced(Runtime& runtime, QueueLease& lease, const SlicePlan& plan, const Cancellation& cancel,
                  const std::string& what, const std::function<void(size_t first, size_t count)>& enqueue) {
  using Clock = std::chrono::steady_clock;
  double budget = plan.first_cost;
  size_t first = 0, slices = 0;
  double next = plan.granules > 0 ? plan.cost(0) : 0;  // the cost of granule `first`
  auto held_since = Clock::now();
  while (first < plan.granules) {
    cancel.check(what);
    size_t end = first;
    double cost = 0;
    do {
      cost += next;
      next = ++end < plan.granules ? plan.cost(end) : 0;
    } while (end < plan.granules && cost + next <= budget);
    if (lease.held() && Clock::now() - held_since >= std::chrono::duration<double>(kSliceSeconds / 2))
      lease.unlock();  // other requests' work goes in between
    if (!lease.held()) {
      lease = runtime.exclusive(plan.kind);
      held_since = Clock::now();
    }
    const auto start = Clock::now();  // the device's time, not the wait for the lease
    enqueue(first * plan.granule, (end - first) * plan.granule);
    ++slices;
    first = end;
    if (first == plan.granules) break;  // the caller's read-back waits for the last slice
    runtime.queue().finish();
    budget = next_cost(budget, cost, std::chrono::duration<double>(Clock::now() - start).count());
  }
  if (!lease.held()) lease = runtime.exclusive(plan.kind);
  return slices;
}

}  // namespace squall
