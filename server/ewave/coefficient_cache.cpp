#include "ewave/coefficient_cache.h"

#include <vector>

#include "ewave/ewave_state_format.h"
#include "ewave/propagator.h"

namespace squall::ewave {

const cl::Buffer& CoefficientCache::get(Runtime& runtime, const EWaveConfig& config, double dt) {
  ++uses_;
  auto found = entries_.find(dt);
  if (found == entries_.end()) {
    if (entries_.size() >= capacity_) evict_oldest();
    std::vector<char> table = to_state_type(propagator_coefficients(config, dt), config.double_precision);
    found = entries_.emplace(dt, Entry{}).first;
    found->second.buffer = runtime.buffers().acquire(table.size());
    runtime.queue().enqueueWriteBuffer(found->second.buffer.buffer(), CL_TRUE, 0, table.size(), table.data());
  }
  found->second.last_use = uses_;
  return found->second.buffer.buffer();
}

void CoefficientCache::evict_oldest() {
  auto oldest = entries_.begin();
  for (auto it = entries_.begin(); it != entries_.end(); ++it)
    if (it->second.last_use < oldest->second.last_use) oldest = it;
  entries_.erase(oldest);
}

}  // namespace squall::ewave
