// A read-only device buffer holding a copy of host values.
#pragma once

#include <vector>

#include "runtime/runtime.h"

namespace squall {

// OpenCL buffers may not be empty: an empty vector gives a few zero bytes (an absent input).
template <typename T>
cl::Buffer upload(Runtime& runtime, const std::vector<T>& values) {
  static const T none[16] = {};
  const void* data = values.empty() ? static_cast<const void*>(none) : values.data();
  const size_t bytes = values.empty() ? sizeof(none) : values.size() * sizeof(T);
  return cl::Buffer(runtime.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, bytes, const_cast<void*>(data));
}

}  // namespace squall
