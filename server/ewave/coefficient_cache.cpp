#include "ewave/coefficient_cache.h"

#include <vector>

#include "common/error.h"
#include "ewave/ewave_state_format.h"
#include "ewave/propagator.h"

namespace squall::ewave {

CoefficientCache::Key CoefficientCache::key_of(const EWaveConfig& c, double dt) {
  Key k;
  k.nx = c.nx, k.ny = c.ny;
  k.length_x = c.length_x(), k.length_y = c.length_y();
  k.gravity = c.gravity, k.depth = c.depth, k.capillary_length = c.capillary_length;
  k.dt = dt;
  k.dispersion = int(c.dispersion);
  k.double_precision = c.double_precision;
  return k;
}

cl::Buffer CoefficientCache::get(const Runtime& runtime, const EWaveConfig& config, double dt) {
  const Key key = key_of(config, dt);
  // Under the lock throughout: sessions that miss the same table at once compute it once.
  std::lock_guard<std::mutex> guard(mutex_);
  for (auto it = entries_.begin(); it != entries_.end(); ++it)
    if (it->key == key) {
      entries_.splice(entries_.begin(), entries_, it);
      return it->buffer;
    }
  std::vector<char> table = to_state_type(propagator_coefficients(config, dt), config.double_precision);
  cl::Buffer buffer(runtime.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, table.size(), table.data());
  ++computed_;
  while (!entries_.empty() && bytes_ + table.size() > max_bytes_) {
    bytes_ -= entries_.back().bytes;
    entries_.pop_back();
  }
  Slot memory;
  if (gate_) {
    try {
      memory = gate_->acquire_memory("an eWave propagator table kept for the next steps", table.size());
    } catch (const Error&) {
      return buffer;  // past the memory budget: used by this step alone
    }
  }
  entries_.push_front(Entry{key, buffer, table.size(), std::move(memory)});
  bytes_ += table.size();
  return buffer;
}

uint64_t CoefficientCache::computed() const {
  std::lock_guard<std::mutex> guard(mutex_);
  return computed_;
}

size_t CoefficientCache::bytes() const {
  std::lock_guard<std::mutex> guard(mutex_);
  return bytes_;
}

}  // namespace squall::ewave
