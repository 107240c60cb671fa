// Device buffers reused across requests of the same shape: a request leases a buffer of an exact byte
// size, and the lease hands it back when it ends, so the next request of that shape allocates nothing.
#pragma once

#include <cstddef>
#include <map>
#include <mutex>

#include "runtime/opencl.h"

namespace squall {

class BufferPool;

// A read-write device buffer held for the lifetime of one request. Movable, not copyable.
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

 private:
  friend class BufferPool;
  BufferLease(BufferPool* pool, cl::Buffer buffer, size_t bytes)
      : pool_(pool), buffer_(std::move(buffer)), bytes_(bytes) {}
  void give_back();

  BufferPool* pool_ = nullptr;
  cl::Buffer buffer_;
  size_t bytes_ = 0;
};

class BufferPool {
 public:
  // Buffers handed back are kept while the idle ones total at most max_idle_bytes. host_memory: the
  // device is a CPU; buffers are allocated with CL_MEM_ALLOC_HOST_PTR so that mapping them (the FFTW
  // backend) does not copy.
  BufferPool(const cl::Context& context, size_t max_idle_bytes, bool host_memory = false);

  BufferLease acquire(size_t bytes);  // bytes > 0

  size_t idle_bytes() const;
  size_t allocations() const;  // clCreateBuffer calls so far: the measure of reuse

 private:
  friend class BufferLease;
  void put_back(cl::Buffer buffer, size_t bytes);

  cl::Context context_;
  size_t max_idle_bytes_;
  cl_mem_flags flags_;
  mutable std::mutex mutex_;
  std::multimap<size_t, cl::Buffer> idle_;
  size_t idle_bytes_ = 0;
  size_t allocations_ = 0;
};

}  // namespace squall
