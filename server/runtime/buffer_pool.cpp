#include "runtime/buffer_pool.h"

#include <cstdlib>

#include "common/error.h"
#include "runtime/kernel.h"

namespace squall {

void* host_storage(const cl::Buffer& buffer) {
  if (!(buffer.getInfo<CL_MEM_FLAGS>() & CL_MEM_USE_HOST_PTR)) return nullptr;
  return buffer.getInfo<CL_MEM_HOST_PTR>();
}

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
    : context_(context), max_idle_bytes_(max_idle_bytes), host_memory_(host_memory), held_slot_(std::move(held_slot)) {}

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
  return BufferLease(this, allocate(bytes), bytes);
}

// On a CPU device, over memory of its own that the buffer's destructor callback frees once the runtime
// has released it (after the last command that uses it).
cl::Buffer BufferPool::allocate(size_t bytes) const {
  if (!host_memory_) return cl::Buffer(context_, CL_MEM_READ_WRITE, bytes);
  void* memory = std::aligned_alloc(kHostAlignment, round_up(bytes, kHostAlignment));
  if (!memory)
    fail(Code::ResourceExhausted, "no host memory for a device buffer of " + std::to_string(bytes) + " bytes");
  cl::Buffer buffer;
  try {
    buffer = cl::Buffer(context_, CL_MEM_READ_WRITE | CL_MEM_USE_HOST_PTR, bytes, memory);
    buffer.setDestructorCallback([](cl_mem, void* p) { std::free(p); }, memory);
  } catch (...) {
    buffer = cl::Buffer();  // released before the memory it was made over
    std::free(memory);
    throw;
  }
  return buffer;
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
