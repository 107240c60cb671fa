// The propagator tables of an eWave session on the device (propagator_coefficients, in the state's type),
// kept by dt for the few most recent dt (least recently used evicted): a session stepping with a
// constant dt uploads its table once.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>

#include "ewave/ewave_config.h"
#include "runtime/runtime.h"

namespace squall::ewave {

class CoefficientCache {
 public:
  explicit CoefficientCache(size_t capacity = 4) : capacity_(capacity) {}

  // The table of (config, dt), computed and uploaded (blocking) on a miss. Under runtime.exclusive().
  const cl::Buffer& get(Runtime& runtime, const EWaveConfig& config, double dt);
  void clear() { entries_.clear(); }  // after the config changed (restore)

 private:
  struct Entry {
    BufferLease buffer;
    uint64_t last_use = 0;
  };
  void evict_oldest();

  size_t capacity_;
  std::map<double, Entry> entries_;
  uint64_t uses_ = 0;
};

}  // namespace squall::ewave
