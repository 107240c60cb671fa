// ByteWriter and ByteReader: the one codec for the bytes squall keeps beyond a request (session
// checkpoints, ocean tile specs, eWave states and checkpoint payloads, texture checkpoints), so that each
// format states only its order of values and every reader checks every read the same way.
//
// Byte layout, whatever the host: values back to back, with no padding and no alignment, each
// little-endian (least significant byte first):
//   - an integer or enum: its value in sizeof(T) bytes (signed ones two's complement);
//   - a bool: one byte, 0 or 1;
//   - a float / double: the bits of its IEEE 754 binary32 / binary64 value, as a u32 / u64;
//   - an array: its elements back to back (its count, where the format has one, is a value of its own);
//   - a counted string: a u64 byte length, then the bytes.
// A reader that runs out, finds a bool that is neither 0 nor 1, or has bytes left over throws
// Error(InvalidArgument) "<what> is not <kind>: <why>", e.g. "state is not a session checkpoint: truncated
// at byte 12 of 30 (reading the id length)". A length or count is checked against the bytes left before
// anything is allocated for it, so a forged one cannot make the reader allocate more than the data holds.
#pragma once

#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "common/error.h"

namespace squall {

// The values the codec writes: integers, enums, bool, and IEEE 754 float / double.
template <typename T>
concept ByteValue = (std::is_integral_v<T> || std::is_enum_v<T> ||
                     (std::is_floating_point_v<T> && std::numeric_limits<T>::is_iec559)) &&
                    (sizeof(T) == 1 || sizeof(T) == 2 || sizeof(T) == 4 || sizeof(T) == 8);

// The values an array may hold: not bool, whose bytes other than 0 and 1 would be no bool when copied.
template <typename T>
concept ByteArrayValue = ByteValue<T> && !std::is_same_v<T, bool>;

namespace byte_codec_detail {

template <size_t N>
using Unsigned =
    std::conditional_t<N == 1, uint8_t,
                       std::conditional_t<N == 2, uint16_t, std::conditional_t<N == 4, uint32_t, uint64_t>>>;

// The bits of a value, as the unsigned integer of its size.
template <ByteValue T>
Unsigned<sizeof(T)> bits_of(T value) {
  if constexpr (std::is_enum_v<T>) {
    return static_cast<Unsigned<sizeof(T)>>(static_cast<std::underlying_type_t<T>>(value));
  } else if constexpr (std::is_floating_point_v<T>) {
    return std::bit_cast<Unsigned<sizeof(T)>>(value);
  } else {
    return static_cast<Unsigned<sizeof(T)>>(value);  // two's complement (C++20), and bool as 0 or 1
  }
}

// On a little-endian host, an array's bytes are its memory; elsewhere each element is converted.
constexpr bool kHostIsLittleEndian = std::endian::native == std::endian::little;

}  // namespace byte_codec_detail

// Appends values in the layout above.
class ByteWriter {
 public:
  ByteWriter() = default;
  // Appends after `start` (e.g. a header the caller laid out), without copying it.
  explicit ByteWriter(std::string start) : bytes_(std::move(start)) {}

  template <ByteValue T>
  void put(T value) {
    const auto bits = byte_codec_detail::bits_of(value);
    for (size_t b = 0; b < sizeof(T); ++b) bytes_.push_back(char(uint8_t(uint64_t(bits) >> (8 * b))));
  }
  template <ByteArrayValue T>
  void put_array(const T* values, size_t count) {
    if constexpr (byte_codec_detail::kHostIsLittleEndian) {
      bytes_.append(reinterpret_cast<const char*>(values), count * sizeof(T));
    } else {
      for (size_t i = 0; i < count; ++i) put(values[i]);
    }
  }
  void put_bytes(std::string_view bytes) { bytes_.append(bytes); }
  // A u64 length, then the bytes.
  void put_counted(std::string_view bytes) {
    put(uint64_t(bytes.size()));
    put_bytes(bytes);
  }

  size_t size() const { return bytes_.size(); }
  std::string take() { return std::move(bytes_); }

 private:
  std::string bytes_;
};

// Reads values in the layout above, front to back, from bytes that must outlive it. `member` names what a
// read is for in the message when it fails ("the id length", "spec.layers[0].lx").
class ByteReader {
 public:
  ByteReader(std::string_view bytes, std::string what, std::string kind)
      : bytes_(bytes), what_(std::move(what)), kind_(std::move(kind)) {}

  template <ByteValue T>
  T get(std::string_view member) {
    need(1, sizeof(T), member, "");
    uint64_t bits = 0;
    for (size_t b = 0; b < sizeof(T); ++b) bits |= uint64_t(uint8_t(bytes_[at_ + b])) << (8 * b);
    at_ += sizeof(T);
    return value_of<T>(static_cast<byte_codec_detail::Unsigned<sizeof(T)>>(bits), member);
  }
  // `count` values; a count past the end is rejected before the vector is allocated.
  template <ByteArrayValue T>
  std::vector<T> get_array(uint64_t count, std::string_view member) {
    need(count, sizeof(T), member, ": " + std::to_string(count) + " values of " + std::to_string(sizeof(T)) + " bytes");
    std::vector<T> values(count);
    if constexpr (byte_codec_detail::kHostIsLittleEndian) {
      std::memcpy(values.data(), bytes_.data() + at_, count * sizeof(T));
      at_ += count * sizeof(T);
    } else {
      for (T& value : values) value = get<T>(member);
    }
    return values;
  }
  // The next n bytes, in place.
  std::string_view get_bytes(uint64_t n, std::string_view member) {
    need(n, 1, member, " of " + std::to_string(n) + " bytes");
    const std::string_view bytes = bytes_.substr(at_, n);
    at_ += n;
    return bytes;
  }
  // A u64 length and the bytes it counts, in place: put_counted's bytes.
  std::string_view get_counted(std::string_view member) {
    return get_bytes(get<uint64_t>(std::string(member) + " length"), member);
  }

  size_t offset() const { return at_; }
  size_t left() const { return bytes_.size() - at_; }
  // Rejects the bytes unless all have been read; `last` names what they follow ("the last layer").
  void finish(std::string_view last) const {
    if (left() != 0) reject(std::to_string(left()) + " bytes follow " + std::string(last));
  }
  [[noreturn]] void reject(const std::string& why) const {
    fail(Code::InvalidArgument, what_ + " is not " + kind_ + ": " + why);
  }

 private:
  // Rejects, as truncation, count values of `size` bytes that the bytes left cannot hold (a division, so
  // that no count overflows the product).
  void need(uint64_t count, size_t size, std::string_view member, const std::string& detail) const {
    if (count > left() / size)
      reject("truncated at byte " + std::to_string(at_) + " of " + std::to_string(bytes_.size()) + " (reading " +
             std::string(member) + detail + ")");
  }
  template <ByteValue T>
  T value_of(byte_codec_detail::Unsigned<sizeof(T)> bits, std::string_view member) const {
    if constexpr (std::is_same_v<T, bool>) {
      if (bits > 1) reject(std::string(member) + " = " + std::to_string(bits) + " must be 0 or 1");
      return bits == 1;
    } else if constexpr (std::is_enum_v<T>) {
      return static_cast<T>(static_cast<std::underlying_type_t<T>>(bits));
    } else if constexpr (std::is_floating_point_v<T>) {
      return std::bit_cast<T>(bits);
    } else {
      return static_cast<T>(bits);  // modular (C++20): the two's complement value back
    }
  }

  std::string_view bytes_;
  std::string what_, kind_;
  size_t at_ = 0;
};

}  // namespace squall
