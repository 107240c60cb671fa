#include "runtime/buffer_pool.h"

namespace squall {

BufferLease::BufferLease(BufferLease&& other) noexcept
    : pool_(other.pool_), buffer_(std::move(other.buffer_)), bytes_(other.bytes_) {
  other.pool_ = nullptr;
}

BufferLease& BufferLease::operator=(BufferLease&& other) noexcept {
  if (this != &other) {
    give_back();
    pool_ = other.pool_;
    buffer_ = std::move(other.buffer_);
    bytes_ = other.bytes_;
    other.pool_ = nullptr;
  }
  return *this;
}

BufferLease::~BufferLease() { give_back(); }

void BufferLease::give_back() {
  if (pool_) pool_->put_back(std::move(buffer_), bytes_);
  pool_ = nullptr;
}

BufferPool::BufferPool(const cl::Context& context, size_t max_idle_bytes, bool host_memory,
                       std::function<int()> held_slot)
    : context_(context),
      max_idle_bytes_(max_idle_bytes),
      flags_(CL_MEM_READ_WRITE | (host_memory ? CL_MEM_ALLOC_HOST_PTR : 0)),
      held_slot_(std::move(held_slot)) {}

BufferLease BufferPool::acquire(size_t bytes) {
  const int slot = held_slot_();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto [first, last] = idle_.equal_range(bytes);
    for (auto it = first; it != last; ++it) {
      if (it->second.slot >= 0 && it->second.slot != slot) continue;  // another queue's work may use it
      cl::Buffer buffer = std::move(it->second.buffer);
      idle_.erase(it);
      idle_bytes_ -= bytes;
      return BufferLease(this, std::move(buffer), bytes);
    }
    ++allocations_;
  }
  return BufferLease(this, cl::Buffer(context_, flags_, bytes), bytes);
}

void BufferPool::put_back(cl::Buffer buffer, size_t bytes) {
  const int slot = held_slot_();
  std::lock_guard<std::mutex> lock(mutex_);
  if (idle_bytes_ + bytes > max_idle_bytes_) return;  // dropped: released by cl::Buffer
  idle_.emplace(bytes, Idle{std::move(buffer), slot});
  idle_bytes_ += bytes;
}

void BufferPool::settle(int slot) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (auto& [bytes, idle] : idle_)
    if (idle.slot == slot) idle.slot = -1;
}

size_t BufferPool::idle_bytes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return idle_bytes_;
}

size_t BufferPool::allocations() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return allocations_;
}

}  // namespace squall
