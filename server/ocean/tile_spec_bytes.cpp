#include "ocean/tile_spec_bytes.h"

#include <bit>
#include <cstdint>
#include <limits>
#include <vector>

#include "common/error.h"
#include "common/limits.h"
#include "common/validate.h"
#include "ocean/spectrum_setup.h"

namespace squall::ocean {
namespace {

constexpr char kMagic[8] = {'S', 'Q', 'O', 'C', 'N', 'S', 'P', 'C'};

// A member added to these structs must be added to the lists below (and the format version raised).
static_assert(sizeof(PartialSpectrum) == 56 && sizeof(LayerSpec) == 216 && sizeof(TileSpec) == 104,
              "the ocean specs changed: list the new member in tile_spec_bytes");

std::string join(const std::string& path, const std::string& field) {
  return path.empty() ? field : path + "." + field;
}

// The members of the layout (tile_spec_bytes.h), each listed once, in order, for both directions: `io` is
// a Writer (Spec const) or a Reader; `path` names the member in the Reader's messages.
template <typename Io, typename Partial>
void partial_members(Io& io, Partial& p, const std::string& path) {
  io.f64(path + ".peak_frequency", p.peak_frequency);
  io.f64(path + ".significant_wave_height", p.significant_wave_height);
  io.f64(path + ".a", p.a);
  io.f64(path + ".b", p.b);
  io.f64(path + ".c", p.c);
  io.f64(path + ".n", p.n);
  io.f64(path + ".m", p.m);
}

template <typename Io, typename Layer>
void layer_members(Io& io, Layer& L, const std::string& path) {
  io.f64(path + ".lx", L.lx);
  io.f64(path + ".ly", L.ly);
  io.i64(path + ".nx", L.nx);
  io.i64(path + ".ny", L.ny);
  io.enumeration(path + ".spectrum", L.spectrum);
  io.f64(path + ".wind_speed", L.wind_speed);
  io.f64(path + ".fetch", L.fetch);
  io.f64(path + ".gamma", L.gamma);
  io.f64(path + ".sigma_a", L.sigma_a);
  io.f64(path + ".sigma_b", L.sigma_b);
  io.f64(path + ".phillips_amplitude", L.phillips_amplitude);
  io.f64(path + ".phillips_cutoff", L.phillips_cutoff);
  io.f64(path + ".phillips_exponent", L.phillips_exponent);
  io.sequence(path + ".partials", L.partials, [&](auto& p, const std::string& at) { partial_members(io, p, at); });
  io.enumeration(path + ".spreading", L.spreading);
  io.f64(path + ".wind_direction", L.wind_direction);
  io.enumeration(path + ".dispersion", L.dispersion);
  io.f64(path + ".depth", L.depth);
  io.f64(path + ".capillary_length", L.capillary_length);
  io.f64(path + ".gravity", L.gravity);
  io.u64(path + ".seed", L.seed);
  io.f64(path + ".drift_x", L.drift_x);
  io.f64(path + ".drift_y", L.drift_y);
  io.f64(path + ".k_min", L.k_min);
  io.f64(path + ".k_max", L.k_max);
}

template <typename Io, typename Tile>
void tile_members(Io& io, Tile& spec, const std::string& path) {
  io.flag(join(path, "b_correction"), spec.b_correction);
  io.f64(join(path, "choppiness"), spec.choppiness);
  io.i64(join(path, "nx"), spec.nx);
  io.i64(join(path, "ny"), spec.ny);
  io.f64(join(path, "lx"), spec.lx);
  io.f64(join(path, "ly"), spec.ly);
  io.f64(join(path, "whitecap_threshold"), spec.whitecap_threshold);
  io.f64(join(path, "whitecap_decay"), spec.whitecap_decay);
  io.f64(join(path, "pixel_scale"), spec.pixel_scale);
  io.f64(join(path, "slope_k_max"), spec.slope_k_max);
  io.sequence(join(path, "layers"), spec.layers, [&](auto& L, const std::string& at) { layer_members(io, L, at); });
}

// Appends each member as its `size` low-order bytes, least significant first.
class Writer {
 public:
  std::string out;

  void put(uint64_t value, int size) {
    for (int b = 0; b < size; ++b) out.push_back(char(uint8_t(value >> (8 * b))));
  }
  void flag(const std::string&, bool v) { put(v ? 1 : 0, 1); }
  void f64(const std::string&, double v) { put(std::bit_cast<uint64_t>(v), 8); }
  void i64(const std::string&, int64_t v) { put(static_cast<uint64_t>(v), 8); }
  void u64(const std::string&, uint64_t v) { put(v, 8); }
  template <typename E>
  void enumeration(const std::string&, E v) {
    put(static_cast<uint32_t>(static_cast<int32_t>(v)), 4);
  }
  template <typename T, typename F>
  void sequence(const std::string& path, const std::vector<T>& items, F&& each) {
    if (items.size() > std::numeric_limits<uint32_t>::max())
      fail(Code::InvalidArgument, path + " has " + std::to_string(items.size()) + " entries: too many to encode");
    put(items.size(), 4);
    for (size_t i = 0; i < items.size(); ++i) each(items[i], validate::at(path, i));
  }
};

// Reads the members front to back; a read past the end is InvalidArgument naming the member.
class Reader {
 public:
  Reader(std::string_view bytes, const std::string& path) : bytes_(bytes), path_(path.empty() ? "bytes" : path) {}

  uint64_t get(const std::string& member, size_t size) {
    if (size > bytes_.size() - at_)
      reject("truncated at byte " + std::to_string(at_) + " of " + std::to_string(bytes_.size()) + " (reading " +
             member + ")");
    uint64_t value = 0;
    for (size_t b = 0; b < size; ++b) value |= uint64_t(uint8_t(bytes_[at_ + b])) << (8 * b);
    at_ += size;
    return value;
  }
  void flag(const std::string& member, bool& v) {
    const uint64_t byte = get(member, 1);
    if (byte > 1) validate::reject(member, std::to_string(byte), "0 or 1");
    v = byte == 1;
  }
  void f64(const std::string& member, double& v) { v = std::bit_cast<double>(get(member, 8)); }
  void i64(const std::string& member, int64_t& v) { v = static_cast<int64_t>(get(member, 8)); }
  void u64(const std::string& member, uint64_t& v) { v = get(member, 8); }
  template <typename E>
  void enumeration(const std::string& member, E& v) {
    v = E(static_cast<int32_t>(static_cast<uint32_t>(get(member, 4))));
  }
  // The entries one by one, as the bytes hold them: a count past the end is caught as truncation at the
  // first entry missing, before anything is allocated for the rest.
  template <typename T, typename F>
  void sequence(const std::string& path, std::vector<T>& items, F&& each) {
    const uint64_t count = get(path + " count", 4);
    items.clear();
    for (uint64_t i = 0; i < count; ++i) {
      items.emplace_back();
      each(items.back(), validate::at(path, i));
    }
  }
  void finish() const {
    if (at_ != bytes_.size()) reject(std::to_string(bytes_.size() - at_) + " bytes follow the last layer");
  }
  [[noreturn]] void reject(const std::string& why) const {
    fail(Code::InvalidArgument, path_ + " is not an ocean tile spec: " + why);
  }

 private:
  std::string_view bytes_;
  const std::string path_;
  size_t at_ = 0;
};

}  // namespace

std::string encode_tile_spec(const TileSpec& spec) {
  Writer out;
  out.out.assign(kMagic, sizeof kMagic);
  out.put(kTileSpecBytesVersion, 4);
  tile_members(out, spec, "");
  return std::move(out.out);
}

TileSpec decode_tile_spec(std::string_view bytes, const LimitGate& gate, const std::string& path) {
  Reader in(bytes, path);
  if (bytes.substr(0, sizeof kMagic) != std::string_view(kMagic, sizeof kMagic))
    in.reject("it does not start with the magic \"SQOCNSPC\"");
  in.get("magic", sizeof kMagic);
  if (const uint64_t version = in.get("format version", 4); version != kTileSpecBytesVersion)
    in.reject("format version " + std::to_string(version) + "; this squalld reads version " +
              std::to_string(kTileSpecBytesVersion));
  TileSpec spec;
  tile_members(in, spec, path);
  in.finish();
  validate_tile(spec, gate, path);
  return spec;
}

}  // namespace squall::ocean
