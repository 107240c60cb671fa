#include "ocean/tile_spec_bytes.h"

#include <cstdint>
#include <limits>
#include <vector>

#include "common/byte_codec.h"
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

// The member adapters of the lists above over the byte codec (common/byte_codec.h): an enum is an i32 and
// a count a u32, whatever their types in the structs.
class Writer {
 public:
  ByteWriter out;

  void flag(const std::string&, bool v) { out.put(v); }
  void f64(const std::string&, double v) { out.put(v); }
  void i64(const std::string&, int64_t v) { out.put(v); }
  void u64(const std::string&, uint64_t v) { out.put(v); }
  template <typename E>
  void enumeration(const std::string&, E v) {
    out.put(static_cast<int32_t>(v));
  }
  template <typename T, typename F>
  void sequence(const std::string& path, const std::vector<T>& items, F&& each) {
    if (items.size() > std::numeric_limits<uint32_t>::max())
      fail(Code::InvalidArgument, path + " has " + std::to_string(items.size()) + " entries: too many to encode");
    out.put(uint32_t(items.size()));
    for (size_t i = 0; i < items.size(); ++i) each(items[i], validate::at(path, i));
  }
};

class Reader {
 public:
  ByteReader in;

  void flag(const std::string& member, bool& v) { v = in.get<bool>(member); }
  void f64(const std::string& member, double& v) { v = in.get<double>(member); }
  void i64(const std::string& member, int64_t& v) { v = in.get<int64_t>(member); }
  void u64(const std::string& member, uint64_t& v) { v = in.get<uint64_t>(member); }
  template <typename E>
  void enumeration(const std::string& member, E& v) {
    v = E(in.get<int32_t>(member));
  }
  // The entries one by one, as the bytes hold them: a count past the end is caught as truncation at the
  // first entry missing, before anything is allocated for the rest.
  template <typename T, typename F>
  void sequence(const std::string& path, std::vector<T>& items, F&& each) {
    const uint32_t count = in.get<uint32_t>(path + " count");
    items.clear();
    for (uint32_t i = 0; i < count; ++i) {
      items.emplace_back();
      each(items.back(), validate::at(path, i));
    }
  }
};

}  // namespace

std::string encode_tile_spec(const TileSpec& spec) {
  Writer out;
  out.out.put_bytes(std::string_view(kMagic, sizeof kMagic));
  out.out.put(kTileSpecBytesVersion);
  tile_members(out, spec, "");
  return out.out.take();
}

TileSpec decode_tile_spec(std::string_view bytes, const LimitGate& gate, const std::string& path) {
  Reader reader{ByteReader(bytes, path.empty() ? "bytes" : path, "an ocean tile spec")};
  ByteReader& in = reader.in;
  if (bytes.substr(0, sizeof kMagic) != std::string_view(kMagic, sizeof kMagic))
    in.reject("it does not start with the magic \"SQOCNSPC\"");
  in.get_bytes(sizeof kMagic, "magic");
  if (const uint32_t version = in.get<uint32_t>("format version"); version != kTileSpecBytesVersion)
    in.reject("format version " + std::to_string(version) + "; this squalld reads version " +
              std::to_string(kTileSpecBytesVersion));
  TileSpec spec;
  tile_members(reader, spec, path);
  in.finish("the last layer");
  validate_tile(spec, gate, path);
  return spec;
}

}  // namespace squall::ocean
