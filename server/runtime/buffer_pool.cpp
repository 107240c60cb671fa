#include "runtime/buffer_pool.h"

#include <cstdlib>
#include <iterator>
#include <utility>

#include "common/error.h"
#include "runtime/kernel.h"

namespace squall {

void* host_storage(const cl::Buffer& buffer) {
  if (!(buffer.getInfo<CL_MEM_FLAGS>() & CL_MEM_USE_HOST_PTR)) return nullptr;
  return buffer.getInfo<CL_MEM_HOST_PTR>();
}

BufferLease::BufferLease(BufferLease&& other) noexcept
    : pool_(other.pool_), buffer_(std::move(other.buffer_)), mapping_(std::move(other.mapping_)), bytes_(other.bytes_) {
  other.pool_ = nullptr;
}

BufferLease& BufferLease::operator=(BufferLease&& other) noexcept {
  if (this != &other) {
    give_back();
    pool_ = other.pool_;
    buffer_ = std::move(other.buffer_);
    mapping_ = std::move(other.mapping_);
    bytes_ = other.bytes_;
    other.pool_ = nullptr;
  }
  return *this;
}

BufferLease::~BufferLease() { give_back(); }

void BufferLease::give_back() {
  if (pool_) pool_->put_back(std::move(buffer_), std::move(mapping_), bytes_);
  pool_ = nullptr;
}

BufferPool::BufferPool(const cl::Context& context, size_t max_idle_bytes, bool host_memory,
                       std::function<int()> held_slot)
    : context_(context), max_idle_bytes_(max_idle_bytes), host_memory_(host_memory), held_slot_(std::move(held_slot)) {}

BufferLease BufferPool::acquire(size_t bytes, Memory memory) {
  const int slot = held_slot_();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto [first, last] = idle_.equal_range(Key{bytes, memory});
    for (auto it = first; it != last; ++it) {
      if (it->second.slot >= 0 && it->second.slot != slot) continue;  // another queue's work may use it
      Idle idle = std::move(it->second);
      idle_.erase(it);
      idle_bytes_ -= bytes;
      return BufferLease(this, std::move(idle.buffer), std::move(idle.mapping), bytes);
    }
    ++allocations_;
  }
  if (memory == Memory::Pinned) return allocate_pinned(bytes);
  return BufferLease(this, allocate(bytes), nullptr, bytes);
}

// Mapped once, on a queue of the pool's own (a thread holding a request's queue may hand the buffer back);
// the mapping's last holder enqueues the unmap there, before the buffer is released.
BufferLease BufferPool::allocate_pinned(size_t bytes) {
  std::call_once(mapping_queue_made_, [this] {
    mapping_queue_ = cl::CommandQueue(context_, context_.getInfo<CL_CONTEXT_DEVICES>().front());
  });
  cl::Buffer buffer(context_, CL_MEM_READ_WRITE | CL_MEM_ALLOC_HOST_PTR, bytes);
  void* host = mapping_queue_.enqueueMapBuffer(buffer, CL_TRUE, CL_MAP_READ | CL_MAP_WRITE, 0, bytes);
  std::shared_ptr<void> mapping(host, [buffer, queue = mapping_queue_](void* p) {
    clEnqueueUnmapMemObject(queue(), buffer(), p, 0, nullptr, nullptr);  // no throw from a deleter
    clFlush(queue());
  });
  return BufferLease(this, std::move(buffer), std::move(mapping), bytes);
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

void BufferPool::put_back(cl::Buffer buffer, std::shared_ptr<void> mapping, size_t bytes) {
  const int slot = held_slot_();
  std::lock_guard<std::mutex> lock(mutex_);
  if (idle_bytes_ + bytes > max_idle_bytes_) return;  // dropped: released by cl::Buffer
  Slot budget;
  if (gate_) {
    if (!gate_->memory_room(bytes)) return;  // dropped: the budget's room is the calls'
    try {
      budget = gate_->acquire_cache_memory(mapping ? "an idle pinned buffer" : "an idle device buffer", bytes);
    } catch (const Error&) {  // taken meanwhile
      return;
    }
  }
  const Key key{bytes, mapping ? Memory::Pinned : Memory::Device};
  idle_.emplace(key, Idle{std::move(buffer), std::move(mapping), slot, std::move(budget)});
  idle_bytes_ += bytes;
}

// The gate's reclaimer list is changed outside mutex_: a call taking memory back holds the gate's lock and
// then takes mutex_ (reclaim()).
void BufferPool::attach(LimitGate* gate) {
  LimitGate* old = nullptr;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    old = std::exchange(gate_, nullptr);
  }
  if (old) old->remove_reclaimer(this);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    idle_.clear();  // what was counted in the old gate goes with it; nothing idle is counted in the new one
    idle_bytes_ = 0;
    gate_ = gate;
  }
  if (gate) gate->add_reclaimer(this);
}

uint64_t BufferPool::reclaim(uint64_t bytes) {
  std::lock_guard<std::mutex> lock(mutex_);
  uint64_t freed = 0;
  while (freed < bytes && !idle_.empty()) {
    auto largest = std::prev(idle_.end());
    freed += largest->first.first;
    idle_bytes_ -= largest->first.first;
    idle_.erase(largest);  // released by cl::Buffer (after the commands that use it), its budget given back
  }
  return 0;  // given back at once
}

void BufferPool::settle(int slot) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (auto& [key, idle] : idle_)
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
