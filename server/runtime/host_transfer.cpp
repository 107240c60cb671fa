#include "runtime/host_transfer.h"

#include <cstring>

#include "runtime/buffer_pool.h"
#include "runtime/runtime.h"

namespace squall {

ReadBack::ReadBack(const Runtime& runtime) : queue_(runtime.queue()), direct_(runtime.computes_in_host_storage()) {}

void ReadBack::add(const cl::Buffer& from, size_t offset, size_t bytes, void* into) {
  const void* storage = direct_ ? host_storage(from) : nullptr;
  if (storage) {
    copies_.push_back({static_cast<const std::byte*>(storage) + offset, bytes, into});
    return;
  }
  queue_.enqueueReadBuffer(from, CL_FALSE, offset, bytes, into);
  ++commands_;
}

void ReadBack::wait() {
  queue_.finish();
  for (const Copy& c : copies_) std::memcpy(c.into, c.from, c.bytes);
  copies_.clear();
}

void read_back(const Runtime& runtime, const cl::Buffer& from, size_t bytes, void* into) {
  ReadBack read(runtime);
  read.add(from, 0, bytes, into);
  read.wait();
}

bool write_buffer(const Runtime& runtime, const cl::Buffer& to, size_t bytes, const void* from) {
  void* storage = runtime.computes_in_host_storage() ? host_storage(to) : nullptr;
  if (!storage) {
    runtime.queue().enqueueWriteBuffer(to, CL_FALSE, 0, bytes, from);
    return true;
  }
  runtime.queue().finish();
  std::memcpy(storage, from, bytes);
  return false;
}

}  // namespace squall
