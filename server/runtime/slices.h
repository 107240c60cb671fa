// Device work too long for one launch runs in slices of its index space along one axis: each slice is
// enqueued under a lease of a device queue (Runtime::exclusive()), waited for and timed (but the last, which
// the caller's read-back waits for); between slices the caller's cancellation is checked and, once the
// lease has been held for half a slice's time, it is given back (other requests' work goes in between).
// Slices are sized by the estimated cost of their granules toward kSliceSeconds at the rate the last slice
// ran, so a GPU does a whole image in a few launches while a CPU device stops within about one slice of a
// cancel, even where cheap granules (rays that miss a cloud) come before costly ones.
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

// The sliced axis: granules (work-groups) of `granule` ids, each with an estimated cost in any unit
// proportional to its device time (density samples, say). Only ratios of costs matter.
struct SlicePlan {
  size_t granules = 0;
  size_t granule = 1;
  std::function<double(size_t)> cost = [](size_t) { return 1.0; };  // granule g's cost, > 0; uniform by default
  double first_cost = 1;  // the first slice's cost: small, the rate is not known yet
  WorkKind kind;          // what the slices' leases are for (Runtime::exclusive)
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

// Calls enqueue(first, count) (in ids) for consecutive slices covering the plan's granules, each but the
// last followed by a wait (the last may still run on return: the caller's blocking read-back on the same
// queue, or the lease's end, waits for it); a slice is at least one granule; throws Error(Cancelled)
// naming `what` when cancel is requested between slices. Returns the number of slices. The slices run
// under `lease` (taken here when it is not held): kept from one slice to the next until it has been held
// for half of kSliceSeconds, then given back and taken anew, so that a short job takes a device queue once
// and a long one lets other requests' work in after about every slice. It is held on return, for the
// caller to read back the results on its queue.
size_t run_sliced(Runtime& runtime, QueueLease& lease, const SlicePlan& plan, const Cancellation& cancel,
                  const std::string& what, const std::function<void(size_t first, size_t count)>& enqueue);

}  // namespace squall
