#include "runtime/host_transfer.h"

#include <cstdint>
#include <cstring>

#include "common/error.h"
#include "runtime/buffer_pool.h"
#include "runtime/runtime.h"

namespace squall {
namespace {

// A read command would fail with CL_INVALID_VALUE; a copy would overrun the buffer's host storage.
void check_within(const cl::Buffer& buffer, size_t offset, size_t bytes, const char* what) {
  const size_t size = buffer.getInfo<CL_MEM_SIZE>();
  if (offset > size || bytes > size - offset)
    fail(Code::Internal, std::string(what) + " of " + std::to_string(bytes) + " bytes at " + std::to_string(offset) +
                             " runs past the end of a buffer of " + std::to_string(size));
}

}  // namespace

void* computed_host_storage(const Runtime& runtime, const cl::Buffer& buffer) {
  if (!runtime.computes_in_host_storage()) return nullptr;
  void* storage = host_storage(buffer);
  return reinterpret_cast<uintptr_t>(storage) % kHostAlignment == 0 ? storage : nullptr;
}

ReadBack::ReadBack(const Runtime& runtime) : runtime_(runtime), queue_(runtime.queue()) {}

ReadBack::~ReadBack() {
  if (reading_) clFinish(queue_());  // no throw from a destructor: the status is dropped
}

void ReadBack::add(const cl::Buffer& from, size_t offset, size_t bytes, void* into) {
  const void* storage = computed_host_storage(runtime_, from);
  if (storage) {
    check_within(from, offset, bytes, "a read");
    copies_.push_back({static_cast<const std::byte*>(storage) + offset, bytes, into});
    return;
  }
  queue_.enqueueReadBuffer(from, CL_FALSE, offset, bytes, into);
  ++commands_;
  reading_ = true;
}

void ReadBack::wait() {
  queue_.finish();
  reading_ = false;
  for (const Copy& c : copies_) std::memcpy(c.into, c.from, c.bytes);
  copies_.clear();
}

void read_back(const Runtime& runtime, const cl::Buffer& from, size_t bytes, void* into) {
  ReadBack read(runtime);
  read.add(from, 0, bytes, into);
  read.wait();
}

std::vector<FloatRange> contiguous_runs(std::span<const FloatRange> ranges) {
  std::vector<FloatRange> runs;
  for (const FloatRange& r : ranges) {
    if (r.count == 0) continue;  // reads nothing, wherever it is
    if (!runs.empty() && runs.back().offset + runs.back().count == r.offset)
      runs.back().count += r.count;
    else
      runs.push_back(r);
  }
  return runs;
}

std::vector<FloatView> read_views(Runtime& runtime, BufferLease lease, std::span<const FloatRange> ranges) {
  size_t total = 0;
  for (const FloatRange& r : ranges) {
    check_within(lease.buffer(), r.offset * sizeof(float), r.count * sizeof(float), "a view");
    total += r.count;
  }
  std::vector<FloatView> views;
  views.reserve(ranges.size());
  if (const auto* storage = static_cast<const float*>(computed_host_storage(runtime, lease.buffer()))) {
    runtime.queue().finish();
    auto keeper = std::make_shared<const BufferLease>(std::move(lease));
    for (const FloatRange& r : ranges) views.emplace_back(storage + r.offset, r.count, keeper);
    return views;
  }
  if (total == 0) return std::vector<FloatView>(ranges.size());
  auto pinned = std::make_shared<BufferLease>(runtime.buffers().acquire(total * sizeof(float), Memory::Pinned));
  auto* const block = static_cast<float*>(pinned->host());
  ReadBack read(runtime);  // dropped by a throw, it finishes the queue before the block can go back
  float* into = block;
  for (const FloatRange& run : contiguous_runs(ranges)) {
    read.add(lease.buffer(), run.offset * sizeof(float), run.count * sizeof(float), into);
    into += run.count;
  }
  read.wait();
  const float* at = block;
  for (const FloatRange& r : ranges) {
    views.emplace_back(at, r.count, pinned);
    at += r.count;
  }
  return views;
}

bool write_buffer(const Runtime& runtime, const cl::Buffer& to, size_t bytes, const void* from) {
  void* storage = computed_host_storage(runtime, to);
  if (!storage) {
    runtime.queue().enqueueWriteBuffer(to, CL_FALSE, 0, bytes, from);
    return true;
  }
  check_within(to, 0, bytes, "a write");
  runtime.queue().finish();
  std::memcpy(storage, from, bytes);
  return false;
}

}  // namespace squall
