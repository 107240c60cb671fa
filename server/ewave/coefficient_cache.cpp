#include "ewave/coefficient_cache.h"

#include <algorithm>
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
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    if (cl::Buffer found = find(key); found()) return found;
    if (!computing(key)) break;
    computed_one_.wait(lock);
  }
  computing_.push_back(key);
  lock.unlock();
  cl::Buffer buffer;
  size_t bytes = 0;
  try {
    std::vector<char> table = to_state_type(propagator_coefficients(config, dt), config.double_precision);
    bytes = table.size();
    buffer = cl::Buffer(runtime.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, bytes, table.data());
  } catch (...) {
    lock.lock();
    std::erase(computing_, key);
    computed_one_.notify_all();
    throw;
  }
  lock.lock();
  std::erase(computing_, key);
  ++computed_;
  computed_one_.notify_all();  // the waiters run once the lock is free: after keep(), or after its throw
  if (bytes <= max_bytes_) keep(key, buffer, bytes);
  return buffer;
}

cl::Buffer CoefficientCache::find(const Key& key) {
  for (auto it = entries_.begin(); it != entries_.end(); ++it)
    if (it->key == key) {
      entries_.splice(entries_.begin(), entries_, it);
      return it->buffer;
    }
  return cl::Buffer();
}

bool CoefficientCache::computing(const Key& key) const {
  return std::find(computing_.begin(), computing_.end(), key) != computing_.end();
}

void CoefficientCache::keep(const Key& key, const cl::Buffer& buffer, size_t bytes) {
  if (gate_ && !gate_->memory_room(bytes, bytes_)) return;  // it serves its caller alone; the kept stay
  auto evict_oldest = [this] {
    bytes_ -= entries_.back().bytes;
    entries_.pop_back();
  };
  while (!entries_.empty() && bytes_ + bytes > max_bytes_) evict_oldest();
  Slot memory;
  for (bool counted = !gate_; !counted;) {
    try {
      memory = gate_->acquire_memory("an eWave propagator table kept for the next steps", bytes);
      counted = true;
    } catch (const Error&) {
      if (entries_.empty()) return;  // the others' holdings grew meanwhile
      evict_oldest();                // the budget the least recently used tables hold goes to the newest
    }
  }
  entries_.push_front(Entry{key, buffer, bytes, std::move(memory)});
  bytes_ += bytes;
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
