// Device work too long for one launch runs in slices of its index space along one axis: each slice is
// enqueued under Runtime::exclusive(), waited for and timed; between slices the lock is free (other
// requests' work goes in between) and the caller's cancellation is checked. Slices grow or shrink toward
// kSliceSeconds, so a GPU does a whole image in a few launches while a CPU device stops within about one
// slice of a cancel.
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "common/cancel.h"
#include "runtime/runtime.h"

namespace squall {

// The time one slice aims at, s. A cancel takes effect after the slice in flight: at most a few times this.
inline constexpr double kSliceSeconds = 0.1;

struct SlicePlan {
  size_t total = 0;        // ids along the sliced axis, a multiple of granule
  size_t granule = 1;      // slices are multiples of this (the work-group size along the axis)
  size_t first_count = 1;  // ids in the first slice (rounded to granule): small, its cost is unknown
};

// A 2D grid of work-groups (tiles) numbered in row order, for slicing 2D work along that order.
struct TileGrid {
  size_t x = 0, y = 0;  // tiles per row, rows
  struct Rect {
    size_t x, y, width, height;  // in tiles
  };
  // Tiles first .. first + count - 1 as at most three rectangles: the end of a row, whole rows, the
  // start of a row.
  std::vector<Rect> rectangles(size_t first, size_t count) const;
};

// Calls enqueue(first, count) for consecutive slices covering [0, plan.total), each under the runtime's
// lock and followed by a wait; throws Error(Cancelled) naming `what` when cancel is requested between
// slices. Returns the number of slices.
size_t run_sliced(Runtime& runtime, const SlicePlan& plan, const Cancellation& cancel, const std::string& what,
                  const std::function<void(size_t first, size_t count)>& enqueue);

}  // namespace squall
