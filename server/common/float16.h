// IEEE 754 binary16 ("half") conversions on the host, for squall.v1.Field with DTYPE_FLOAT16.
// float -> half rounds to nearest, ties to even; overflow goes to +-inf, values below half's smallest
// subnormal round to +-0, NaN stays NaN (quiet, sign kept, top payload bits kept). half -> float is exact.
// Header-only, with no dependencies: the field codec (common/field_codec.h), the services and the client
// use it.
#pragma once

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

namespace squall::f16 {

inline uint16_t from_float(float value) {
  uint32_t f;
  std::memcpy(&f, &value, 4);
  const uint16_t sign = static_cast<uint16_t>((f >> 16) & 0x8000u);
  const uint32_t abs = f & 0x7fffffffu;
  if (abs >= 0x7f800000u) {  // inf or NaN
    if (abs == 0x7f800000u) return sign | 0x7c00u;
    return sign | 0x7e00u | static_cast<uint16_t>((abs >> 13) & 0x3ffu);  // quiet NaN, payload kept
  }
  if (abs >= 0x477ff000u) return sign | 0x7c00u;  // >= 65520 rounds to inf
  if (abs < 0x38800000u) {                        // below 2^-14: half subnormal or zero
    if (abs < 0x33000000u) return sign;           // <= 2^-25 rounds to zero (a tie at 2^-25 goes to even 0)
    const uint32_t exponent = abs >> 23;          // 102 ... 112
    const uint32_t mantissa = (abs & 0x7fffffu) | 0x800000u;
    const uint32_t shift = 126 - exponent;  // 14 ... 24: value = mantissa * 2^(exponent - 150)
    uint32_t half = mantissa >> shift;      // in units of 2^-24
    const uint32_t rest = mantissa & ((1u << shift) - 1);
    const uint32_t tie = 1u << (shift - 1);
    if (rest > tie || (rest == tie && (half & 1u))) ++half;
    return sign | static_cast<uint16_t>(half);
  }
  // Normal: rebias 127 -> 15 and drop 13 mantissa bits, rounding to nearest even (a carry into the
  // exponent is the correct result, including the step up to inf handled above).
  uint32_t half = (abs - 0x38000000u) >> 13;
  const uint32_t rest = abs & 0x1fffu;
  if (rest > 0x1000u || (rest == 0x1000u && (half & 1u))) ++half;
  return sign | static_cast<uint16_t>(half);
}

inline float to_float(uint16_t h) {
  const uint32_t sign = static_cast<uint32_t>(h & 0x8000u) << 16;
  const uint32_t exponent = (h >> 10) & 0x1fu;
  uint32_t mantissa = h & 0x3ffu;
  uint32_t f;
  if (exponent == 0x1fu) {
    f = sign | 0x7f800000u | (mantissa << 13);
  } else if (exponent != 0) {
    f = sign | ((exponent + 112) << 23) | (mantissa << 13);
  } else if (mantissa == 0) {
    f = sign;
  } else {  // subnormal: normalize
    int e = 113;
    while (!(mantissa & 0x400u)) mantissa <<= 1, --e;
    f = sign | (static_cast<uint32_t>(e) << 23) | ((mantissa & 0x3ffu) << 13);
  }
  float out;
  std::memcpy(&out, &f, 4);
  return out;
}

// The index of the first finite value that rounds past half's largest finite value (65504) to +-inf:
// |value| >= 65520. n when there is none.
inline size_t first_overflow(const float* values, size_t n) {
  for (size_t i = 0; i < n; ++i) {
    uint32_t f;
    std::memcpy(&f, &values[i], 4);
    const uint32_t abs = f & 0x7fffffffu;
    if (abs >= 0x477ff000u && abs < 0x7f800000u) return i;
  }
  return n;
}

// Little-endian byte images, as squall.v1.Field.data carries them.
inline void append_half_bytes(const float* values, size_t n, std::string* out) {
  size_t at = out->size();
  out->resize(at + 2 * n);
  for (size_t i = 0; i < n; ++i) {
    uint16_t h = from_float(values[i]);
    (*out)[at + 2 * i] = static_cast<char>(h & 0xff);
    (*out)[at + 2 * i + 1] = static_cast<char>(h >> 8);
  }
}

}  // namespace squall::f16
