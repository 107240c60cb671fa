// The bytes of an advection checkpoint: little-endian values written and read in the same order, each
// read checked against the end of the data (a truncated or foreign checkpoint is INVALID_ARGUMENT).
#pragma once

#include <cstdint>
#include <cstring>
#include <string>
#include <type_traits>
#include <vector>

#include "common/error.h"

namespace squall::textures {

class StateWriter {
 public:
  template <typename T>
  void put(const T& value) {
    static_assert(std::is_trivially_copyable_v<T>);
    bytes_.append(reinterpret_cast<const char*>(&value), sizeof(T));
  }
  template <typename T>
  void put_vector(const std::vector<T>& values) {
    put(uint64_t(values.size()));
    bytes_.append(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(T));
  }
  std::string take() { return std::move(bytes_); }

 private:
  std::string bytes_;
};

class StateReader {
 public:
  explicit StateReader(const std::string& bytes) : bytes_(bytes) {}
  template <typename T>
  T get() {
    static_assert(std::is_trivially_copyable_v<T>);
    T value;
    std::memcpy(&value, take(sizeof(T)), sizeof(T));
    return value;
  }
  template <typename T>
  std::vector<T> get_vector() {
    uint64_t n = get<uint64_t>();
    if (n > (bytes_.size() - offset_) / sizeof(T)) truncated();
    std::vector<T> values(n);
    std::memcpy(values.data(), take(n * sizeof(T)), n * sizeof(T));
    return values;
  }
  // A frame index: InvalidArgument naming resume_state unless it is in [0, max].
  int frame_index(int64_t max) {
    const int64_t index = get<int64_t>();
    if (index < 0 || index > max)
      fail(Code::InvalidArgument, "resume_state holds frame index " + std::to_string(index) +
                                      ": not a frame of a stream (0.." + std::to_string(max) + ")");
    return int(index);
  }
  bool done() const { return offset_ == bytes_.size(); }

 private:
  const char* take(size_t n) {
    if (n > bytes_.size() - offset_) truncated();
    const char* at = bytes_.data() + offset_;
    offset_ += n;
    return at;
  }
  [[noreturn]] static void truncated() {
    fail(Code::InvalidArgument, "resume_state is truncated or not a texture checkpoint");
  }

  const std::string& bytes_;
  size_t offset_ = 0;
};

}  // namespace squall::textures
