#include "clouds/nanovdb_volume.h"

#include <nanovdb/util/OpenToNanoVDB.h>

#include "common/error.h"

namespace squall::clouds {

NanoHandle to_nanovdb(const openvdb::FloatGrid& grid) { return nanovdb::openToNanoVDB(grid); }

cl::Buffer upload_nanovdb(Runtime& runtime, const NanoHandle& handle) {
  if (!handle.grid<float>()) fail(Code::Internal, "NanoVDB handle holds no float grid");
  size_t bytes = (handle.size() + 3) / 4 * 4;
  cl::Buffer buffer(runtime.context(), CL_MEM_READ_ONLY, bytes);
  runtime.queue().enqueueWriteBuffer(buffer, CL_TRUE, 0, handle.size(), handle.data());
  return buffer;
}

cl::Buffer upload_words(Runtime& runtime, const std::vector<uint32_t>& words) {
  const std::vector<uint32_t> none{0};
  const std::vector<uint32_t>& w = words.empty() ? none : words;
  cl::Buffer buffer(runtime.context(), CL_MEM_READ_ONLY, w.size() * sizeof(uint32_t));
  runtime.queue().enqueueWriteBuffer(buffer, CL_TRUE, 0, w.size() * sizeof(uint32_t), w.data());
  return buffer;
}

}  // namespace squall::clouds
