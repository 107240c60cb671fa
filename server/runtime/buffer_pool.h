// Device buffers (and pinned host blocks, Memory::Pinned) reused across requests of the same shape: a
// request leases a buffer of an exact byte size and kind, and the lease hands it back when it ends, so the
// next request of that shape allocates nothing.
// A buffer handed back while its thread holds a device queue may still be in use by work queued there:
// until that queue's lease ends (settle()), only the same queue gets it again, in order after that work.
#pragma once

#include <cstddef>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <utility>

#include "common/limits.h"
#include "runtime/opencl.h"

namespace squall {

class BufferPool;

// The alignment of a CPU device's pool buffers: PoCL's own (CL_DEVICE_MEM_BASE_ADDR_ALIGN, 1024 bits),
// more than any SIMD load needs.
inline constexpr size_t kHostAlignment = 128;

// The host memory a buffer made with CL_MEM_USE_HOST_PTR was made over, as the buffer pool's are on a
// CPU device, whose kernels compute in that memory; null for any other buffer.
void* host_storage(const cl::Buffer& buffer);

// What a pool buffer is: memory of the device, or pinned host memory that the host reads and writes in
// place (a CL_MEM_ALLOC_HOST_PTR buffer, mapped for its lifetime), from which a GPU's DMA engine copies
// with no staging copy of the driver's: the destination of read-backs that the caller keeps.
enum class Memory { Device, Pinned };

// A read-write buffer held for the lifetime of one request (or of what it returns). Movable, not copyable.
class BufferLease {
 public:
  BufferLease() = default;
  BufferLease(BufferLease&& other) noexcept;
  BufferLease& operator=(BufferLease&& other) noexcept;
  BufferLease(const BufferLease&) = delete;
  BufferLease& operator=(const BufferLease&) = delete;
  ~BufferLease();

  const cl::Buffer& buffer() const { return buffer_; }
  size_t bytes() const { return bytes_; }
  void* host() const { return mapping_.get(); }  // a pinned buffer's mapping; null for device memory

 private:
  friend class BufferPool;
  BufferLease(BufferPool* pool, cl::Buffer buffer, std::shared_ptr<void> mapping, size_t bytes)
      : pool_(pool), buffer_(std::move(buffer)), mapping_(std::move(mapping)), bytes_(bytes) {}
  void give_back();

  BufferPool* pool_ = nullptr;
  cl::Buffer buffer_;
  std::shared_ptr<void> mapping_;  // unmaps the buffer when the last holder (a lease, the idle list) goes
  size_t bytes_ = 0;
};

class BufferPool : public MemoryReclaimer {
 public:
  // Buffers handed back are kept while the idle ones total at most max_idle_bytes. host_memory: the
  // device is a CPU, which computes in host memory; each buffer is made over host memory of its own
  // (CL_MEM_USE_HOST_PTR, kHostAlignment bytes aligned), which the FFTW backend's native kernels and a
  // map reach without a copy, and which host_storage() names.
  // held_slot: the queue slot the calling thread holds, -1 for none (held_queue_slot()).
  BufferPool(
      const cl::Context& context, size_t max_idle_bytes, bool host_memory = false,
      std::function<int()> held_slot = [] { return -1; });

  ~BufferPool() override { attach(nullptr); }

  // From now on the idle buffers count in `gate`'s memory budget as cached memory (a call that needs the
  // room takes them back, reclaim()), and a buffer handed back that finds no room there is released. null:
  // no longer; a pool attached is detached before its gate goes.
  void attach(LimitGate* gate);
  uint64_t reclaim(uint64_t bytes) override;  // releases idle buffers, the largest first

  BufferLease acquire(size_t bytes, Memory memory = Memory::Device);  // bytes > 0

  // The lease of queue `slot` has ended and its queue finished: what was handed back under it is free
  // for every queue.
  void settle(int slot);

  size_t idle_bytes() const;
  size_t allocations() const;  // clCreateBuffer calls so far: the measure of reuse

 private:
  friend class BufferLease;
  void put_back(cl::Buffer buffer, std::shared_ptr<void> mapping, size_t bytes);
  cl::Buffer allocate(size_t bytes) const;
  BufferLease allocate_pinned(size_t bytes);

  cl::Context context_;
  size_t max_idle_bytes_;
  bool host_memory_;
  struct Idle {
    cl::Buffer buffer;
    std::shared_ptr<void> mapping;  // a pinned buffer's
    int slot;                       // the queue whose work may still use it, -1 for none
    Slot budget;                    // its bytes in the attached gate's memory budget, as cached memory
  };
  using Key = std::pair<size_t, Memory>;  // bytes first: the largest idle buffer is the last

  std::function<int()> held_slot_;
  std::once_flag mapping_queue_made_;
  cl::CommandQueue mapping_queue_;  // maps and unmaps pinned buffers, made with the first of them
  mutable std::mutex mutex_;
  std::multimap<Key, Idle> idle_;
  size_t idle_bytes_ = 0;
  size_t allocations_ = 0;
  LimitGate* gate_ = nullptr;
};

}  // namespace squall
