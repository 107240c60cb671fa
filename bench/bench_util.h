// Small helpers shared by squall's benchmarks: median timing and table printing.
#pragma once

#include <algorithm>
#include <chrono>
#include <functional>
#include <vector>

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

}  // namespace squall::bench
