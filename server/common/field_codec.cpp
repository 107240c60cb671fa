#include "common/field_codec.h"

#include <algorithm>
#include <bit>
#include <cstring>
#include <limits>

#include "common/error.h"
#include "common/float16.h"
#include "common/validate.h"

namespace squall::field {
namespace {

namespace v1 = squall::v1;

// Field bytes are little-endian; float32 values are copied as they lie in memory.
static_assert(std::endian::native == std::endian::little, "squall.v1.Field bytes assume a little-endian host");

size_t times(size_t a, size_t b) {
  size_t out;
  return __builtin_mul_overflow(a, b, &out) ? std::numeric_limits<size_t>::max() : out;
}

std::string decimal(unsigned __int128 v) {
  std::string digits;
  do digits.insert(digits.begin(), char('0' + int(v % 10)));
  while (v /= 10);
  return digits;
}

// A finite value that float16 would carry as inf is refused, naming the field, the cell and the value.
void refuse_half_overflow(const Header& header, const float* values, size_t count) {
  const size_t k = f16::first_overflow(values, count);
  if (k == count) return;
  const size_t nx = std::max<size_t>(header.nx, 1), ny = std::max<size_t>(header.ny, 1);
  std::string cell = std::to_string(k % nx) + ", " + std::to_string(k / nx % ny);
  if (header.nz > 1) cell += ", " + std::to_string(k / (nx * ny));
  fail(Code::InvalidArgument, header.name + " = " + validate::number(values[k]) + " at (" + cell +
                                  ") is past float16's largest finite value, 65504: ask for DTYPE_FLOAT32");
}

}  // namespace

v1::DType dtype(v1::DType d, const std::string& path) {
  if (d == v1::DTYPE_UNSPECIFIED || d == v1::DTYPE_FLOAT32) return v1::DTYPE_FLOAT32;
  if (d == v1::DTYPE_FLOAT16) return v1::DTYPE_FLOAT16;
  validate::reject(path, std::to_string(int(d)), "DTYPE_FLOAT32 or DTYPE_FLOAT16");
}

size_t bytes_per_value(v1::DType d, const std::string& path) { return dtype(d, path) == v1::DTYPE_FLOAT16 ? 2 : 4; }

size_t value_count(const v1::Field& field) {
  return times(times(field.nx(), field.ny()), std::max<uint32_t>(field.nz(), 1));
}

void append_bytes(const float* values, size_t count, v1::DType d, std::string* out) {
  if (dtype(d) == v1::DTYPE_FLOAT16) {
    f16::append_half_bytes(values, count, out);
  } else {
    out->append(reinterpret_cast<const char*>(values), count * sizeof(float));
  }
}

namespace {
void set_header(const Header& header, v1::Field* out) {
  out->set_name(header.name);
  out->set_unit(header.unit);
  out->set_nx(header.nx);
  out->set_ny(header.ny);
  out->set_nz(header.nz);
  out->set_dtype(dtype(header.dtype));
}
}  // namespace

void encode(const Header& header, const float* values, size_t count, v1::Field* out) {
  const size_t want = times(times(header.nx, header.ny), std::max<uint32_t>(header.nz, 1));
  if (count != want)
    fail(Code::Internal, "field " + header.name + ": " + std::to_string(count) + " values for a grid of " +
                             std::to_string(header.nx) + " x " + std::to_string(header.ny) + " x " +
                             std::to_string(std::max<uint32_t>(header.nz, 1)) + " = " + std::to_string(want));
  if (dtype(header.dtype) == v1::DTYPE_FLOAT16) refuse_half_overflow(header, values, count);
  set_header(header, out);
  std::string* data = out->mutable_data();
  data->clear();
  append_bytes(values, count, out->dtype(), data);
}

std::vector<float> decode_bytes(const std::string& bytes, size_t count, v1::DType d, const std::string& path,
                                const std::string& what) {
  const size_t size = bytes_per_value(d);
  const size_t want = times(count, size);
  if (bytes.size() != want)
    fail(Code::InvalidArgument, path + " has " + std::to_string(bytes.size()) + " bytes, want " + what + " * " +
                                    std::to_string(size) + " = " + std::to_string(want));
  std::vector<float> values(count);
  if (size == 4) {
    std::memcpy(values.data(), bytes.data(), want);
  } else {
    const auto* b = reinterpret_cast<const unsigned char*>(bytes.data());
    for (size_t i = 0; i < count; ++i) values[i] = f16::to_float(uint16_t(b[2 * i] | (b[2 * i + 1] << 8)));
  }
  return values;
}

std::vector<float> decode(const v1::Field& field, const std::string& path) {
  const v1::DType d = dtype(field.dtype(), path + ".dtype");
  const std::string what = field.nz() > 1 ? "nx * ny * nz" : "nx * ny";
  const size_t size = bytes_per_value(d);
  // nx * ny * nz * size in 128 bits (at most 2^98): a grid past 2^64 bytes is named by its exact size.
  const unsigned __int128 bytes = (unsigned __int128)field.nx() * field.ny() * std::max<uint32_t>(field.nz(), 1) * size;
  if (bytes > std::numeric_limits<size_t>::max())
    fail(Code::InvalidArgument, path + ".data has " + std::to_string(field.data().size()) + " bytes, want " + what +
                                    " * " + std::to_string(size) + " = " + decimal(bytes));
  return decode_bytes(field.data(), value_count(field), d, path + ".data", what);
}

}  // namespace squall::field
