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
  if (cl::Buffer found = find(key); found()) return found;
  // Made with no lock held, so that other sessions' steps do not wait for it: sessions missing the same
  // table at once may each make it, and the first to finish keeps it.
  std::vector<char> table = to_state_type(propagator_coefficients(config, dt), config.double_precision);
  cl::Buffer buffer(runtime.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, table.size(), table.data());
  std::lock_guard<std::mutex> guard(mutex_);
  ++computed_;
  for (const Entry& e : entries_)
    if (e.key == key) return e.buffer;
  if (table.size() <= max_bytes_) keep(key, buffer, table.size());
  return buffer;
}

cl::Buffer CoefficientCache::find(const Key& key) {
  std::lock_guard<std::mutex> guard(mutex_);
  for (auto it = entries_.begin(); it != entries_.end(); ++it)
    if (it->key == key) {
      entries_.splice(entries_.begin(), entries_, it);
      return it->buffer;
    }
  return cl::Buffer();
}

void CoefficientCache::keep(const Key& key, const cl::Buffer& buffer, size_t bytes) {
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
      if (entries_.empty()) return;  // past the memory budget: it serves this step alone
      evict_oldest();                // the budget the older tables hold goes to the newest
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
