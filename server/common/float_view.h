// squall::FloatView: a read-only run of floats in host memory, with a share in whatever keeps that memory:
// a vector of its own, or the device buffer (a CPU device's host storage) or pinned host block that an
// engine read its results into. Copies of a view share the floats; to_vector() copies them out. The
// memory goes back to where it came from (a pool) when the last view of it goes.
#pragma once

#include <algorithm>
#include <cstddef>
#include <memory>
#include <span>
#include <utility>
#include <vector>

namespace squall {

class FloatView {
 public:
  using value_type = float;
  using const_iterator = const float*;
  using iterator = const float*;

  FloatView() = default;
  explicit FloatView(std::vector<float> values) {
    auto owned = std::make_shared<const std::vector<float>>(std::move(values));
    data_ = owned->data();
    size_ = owned->size();
    keeper_ = std::move(owned);
  }
  // `size` floats at `data`, which stay valid while `keeper` lives.
  FloatView(const float* data, size_t size, std::shared_ptr<const void> keeper)
      : data_(data), size_(size), keeper_(std::move(keeper)) {}

  const float* data() const { return data_; }
  size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  const float* begin() const { return data_; }
  const float* end() const { return data_ + size_; }
  float operator[](size_t i) const { return data_[i]; }
  operator std::span<const float>() const { return {data_, size_}; }  // NOLINT: a view converts as one
  std::vector<float> to_vector() const { return {begin(), end()}; }

  friend bool operator==(const FloatView& a, const FloatView& b) { return std::ranges::equal(a, b); }

 private:
  const float* data_ = nullptr;
  size_t size_ = 0;
  std::shared_ptr<const void> keeper_;
};

}  // namespace squall
