// squall.v1.Field <-> float values: the one encoder and decoder of Field bytes (little-endian float32, or
// IEEE 754 binary16 rounded to nearest even, see common/float16.h), shared by the services (squall_rpc)
// and the client (squall_client). Its own library, squall_field_codec: it needs protobuf, so it is not
// part of squall_engine.
//
// Request data that does not fit throws squall::Error(InvalidArgument) naming the field path, in the
// style of common/validate.h:
//   "inputs.obstruction.dtype = 9 must be DTYPE_FLOAT32 or DTYPE_FLOAT16"
//   "inputs.obstruction.data has 40 bytes, want nx * ny * 4 = 12288"
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "squall/v1/common.pb.h"

namespace squall::field {

// The element type a request asks for or a Field carries: DTYPE_UNSPECIFIED means DTYPE_FLOAT32 (the
// services' default); DTYPE_FLOAT32 and DTYPE_FLOAT16 pass; any other value is InvalidArgument
// "<path> = 9 must be DTYPE_FLOAT32 or DTYPE_FLOAT16".
squall::v1::DType dtype(squall::v1::DType dtype, const std::string& path = "dtype");

// Bytes of one value: 4 for DTYPE_FLOAT32 (and DTYPE_UNSPECIFIED), 2 for DTYPE_FLOAT16; other values
// are rejected as dtype() rejects them.
size_t bytes_per_value(squall::v1::DType dtype, const std::string& path = "dtype");

// Number of values of a Field's grid: nx * ny * max(nz, 1) (saturating at SIZE_MAX).
size_t value_count(const squall::v1::Field& field);

// Everything of a Field but its values, spacing and origin.
struct Header {
  std::string name;  // e.g. "height"
  std::string unit;  // e.g. "m", "1"
  uint32_t nx = 0, ny = 0;
  uint32_t nz = 0;  // 0 or 1: a 2D field
  squall::v1::DType dtype = squall::v1::DTYPE_FLOAT32;
};

// Sets name, unit, nx, ny, nz, dtype and data of `out` from `values`, which must hold
// nx * ny * max(nz, 1) values (otherwise Error(Internal): a bug of the caller, not of the request).
// As DTYPE_FLOAT16, a finite value past half's range (|value| >= 65520, which would round to inf) is
// Error(InvalidArgument) naming the field, the cell and the value: the request asked for a dtype too
// narrow for its result. Spacing and origin are the caller's to set.
void encode(const Header& header, const float* values, size_t count, squall::v1::Field* out);
inline void encode(const Header& header, const std::vector<float>& values, squall::v1::Field* out) {
  encode(header, values.data(), values.size(), out);
}

// The values of `field` as floats (float16 converted exactly). `path` names the field in messages
// ("inputs.obstruction", "config.initial_height"): a bad dtype rejects "<path>.dtype", a byte count other
// than nx * ny * max(nz, 1) * bytes_per_value rejects "<path>.data". The grid's own shape is the caller's
// to check.
std::vector<float> decode(const squall::v1::Field& field, const std::string& path);

// The raw forms, for byte fields that are not a Field (squall.v1.CloudImage.data):
// appends the bytes of `count` values as `dtype` to `out`;
void append_bytes(const float* values, size_t count, squall::v1::DType dtype, std::string* out);
// the `count` values of `bytes` as `dtype`; a byte count other than count * bytes_per_value is
// InvalidArgument "<path> has 40 bytes, want <what> * 4 = 12288".
std::vector<float> decode_bytes(const std::string& bytes, size_t count, squall::v1::DType dtype,
                                const std::string& path, const std::string& what);

}  // namespace squall::field
