#include "runtime/slices.h"

#include <algorithm>
#include <chrono>

namespace squall {
namespace {

// The next slice's size: the last one's scaled toward kSliceSeconds, by at most 4x either way (one odd
// timing does not swing it), in granules, at least one.
size_t next_count(size_t count, double seconds, size_t granule) {
  const double scale = std::clamp(kSliceSeconds / std::max(seconds, 1e-6), 0.25, 4.0);
  const size_t granules = std::max<size_t>(1, size_t(double(count / granule) * scale));
  return granules * granule;
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

size_t run_sliced(Runtime& runtime, const SlicePlan& plan, const Cancellation& cancel, const std::string& what,
                  const std::function<void(size_t first, size_t count)>& enqueue) {
  const size_t granule = std::max<size_t>(1, plan.granule);
  size_t count = std::max<size_t>(1, plan.first_count / granule) * granule, first = 0, slices = 0;
  while (first < plan.total) {
    cancel.check(what);
    count = std::min(count, plan.total - first);
    double seconds = 0;
    {
      auto lock = runtime.exclusive();
      const auto start = std::chrono::steady_clock::now();  // the device's time, not the wait for the lock
      enqueue(first, count);
      runtime.queue().finish();
      seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    }
    ++slices;
    first += count;
    count = next_count(count, seconds, granule);
  }
  return slices;
}

}  // namespace squall
