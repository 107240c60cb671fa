// Small helpers shared by squall's benchmarks: median timing and goal lines.
#pragma once

#include <malloc.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <exception>
#include <functional>
#include <vector>

#include "absl/synchronization/mutex.h"

namespace squall::bench {

// Runs f once to warm up, then `runs` times; returns the median wall time in seconds.
inline double median_seconds(const std::function<void()>& f, int runs) {
  f();
  std::vector<double> t;
  for (int i = 0; i < runs; ++i) {
    auto start = std::chrono::steady_clock::now();
    f();
    t.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }
  std::sort(t.begin(), t.end());
  return t[t.size() / 2];
}

// A benchmark's main: an error (a device no platform has, a size a backend refuses) is printed as
// "<program>: <what>" with exit status 2, where an uncaught exception would abort.
inline int guarded_main(const char* program, const std::function<int()>& body) {
  try {
    return body();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: %s\n", program, e.what());
    return 2;
  }
}

// One line per goal, the same in every benchmark, so that a script can collect them:
//   "goal on a GPU: ocean 512x512 in process >= 2000 tiles/s: 812 (not met on this device)"
inline void print_gpu_goal(const char* what, double measured, double goal, const char* unit) {
  std::printf("goal on a GPU: %s >= %g %s: %.3g (%s on this device)\n", what, goal, unit, measured,
              measured >= goal ? "met" : "not met");
}

// For a client process that shares the cores with squalld, so should cost little. With glibc's defaults
// the memory of each large reply (from a few hundred KB up) goes back to the kernel when the reply is
// freed, and the next reply faults it in again, zeroed: at 8 load_client threads 100 000 page faults a
// second, half of the process's CPU time. Here blocks of up to 32 MB (the most glibc documents for
// M_MMAP_THRESHOLD) come from the heap, and the heap keeps up to 256 MB of freed memory.
inline void keep_freed_memory() {
  if (!mallopt(M_MMAP_THRESHOLD, 32 << 20) || !mallopt(M_TRIM_THRESHOLD, 256 << 20))
    std::fprintf(stderr, "mallopt refused a threshold: freed memory goes back to the kernel\n");
}

// gRPC's Abseil mutexes, built without NDEBUG as Debian's are, check every lock for lock-order cycles:
// about 0.7% of the two cores at 8 load_client threads. The benchmark clients turn the check off, as
// squalld does.
inline void skip_lock_order_checks() { absl::SetMutexDeadlockDetectionMode(absl::OnDeadlockCycle::kIgnore); }

}  // namespace squall::bench
