// The bytes of an advection checkpoint, in the byte codec's layout (common/byte_codec.h): values written
// and read in the same order, a vector as a u64 count and then its values. A truncated or foreign
// checkpoint is INVALID_ARGUMENT "resume_state is not a texture checkpoint: ...".
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "common/byte_codec.h"
#include "common/error.h"
#include "common/validate.h"

namespace squall::textures {

class StateWriter : public ByteWriter {
 public:
  template <typename T>
  void put_vector(const std::vector<T>& values) {
    put(uint64_t(values.size()));
    put_array(values.data(), values.size());
  }
};

class StateReader : public ByteReader {
 public:
  explicit StateReader(std::string_view bytes) : ByteReader(bytes, "resume_state", "a texture checkpoint") {}

  template <typename T>
  std::vector<T> get_vector(const std::string& member) {
    return get_array<T>(get<uint64_t>(member + " count"), member);
  }
  // A vector of values that are finite, and within +-bound, in every checkpoint: a damaged one is refused
  // here rather than computing planes of NaN.
  template <typename T>
  std::vector<T> get_finite_vector(const std::string& member, double bound = std::numeric_limits<double>::infinity()) {
    std::vector<T> values = get_vector<T>(member);
    for (size_t i = 0; i < values.size(); ++i)
      if (!(std::abs(double(values[i])) <= bound))  // NaN, +-inf and values past the bound
        fail(Code::InvalidArgument, "resume_state holds " + member + " with " + validate::number(values[i]) + " at " +
                                        std::to_string(i) +
                                        ", past what a stream reaches: not a checkpoint of this server");
    return values;
  }
  // A frame index: InvalidArgument naming resume_state unless it is in [0, max].
  int frame_index(int64_t max) {
    const int64_t index = get<int64_t>("the frame index");
    if (index < 0 || index > max)
      fail(Code::InvalidArgument, "resume_state holds frame index " + std::to_string(index) +
                                      ": not a frame of a stream (0.." + std::to_string(max) + ")");
    return int(index);
  }
  bool done() const { return left() == 0; }
};

}  // namespace squall::textures
