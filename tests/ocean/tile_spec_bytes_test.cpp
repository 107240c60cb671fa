// The bytes of an ocean TileSpec (server/ocean/tile_spec_bytes.h): every member round-trips exactly, and
// bytes that are no spec, or hold an invalid one, are InvalidArgument naming what is wrong.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "common/error.h"
#include "common/limits.h"
#include "ocean/tile_spec_bytes.h"
#include "support/expect_error.h"

namespace squall::ocean {
namespace {

using squall::test::expect_error;

// Every member of a spec by name, its value as bits (doubles bit for bit), written out here independently of
// the encoder's own list.
using Members = std::vector<std::pair<std::string, uint64_t>>;

Members members(const TileSpec& s) {
  Members m;
  auto f64 = [&](const std::string& name, double v) { m.emplace_back(name, std::bit_cast<uint64_t>(v)); };
  auto integer = [&](const std::string& name, int64_t v) { m.emplace_back(name, uint64_t(v)); };
  integer("b_correction", s.b_correction);
  f64("choppiness", s.choppiness);
  integer("nx", s.nx);
  integer("ny", s.ny);
  f64("lx", s.lx);
  f64("ly", s.ly);
  f64("whitecap_threshold", s.whitecap_threshold);
  f64("whitecap_decay", s.whitecap_decay);
  f64("pixel_scale", s.pixel_scale);
  f64("slope_k_max", s.slope_k_max);
  integer("layers", int64_t(s.layers.size()));
  for (size_t i = 0; i < s.layers.size(); ++i) {
    const LayerSpec& L = s.layers[i];
    const std::string f = "layers[" + std::to_string(i) + "].";
    f64(f + "lx", L.lx);
    f64(f + "ly", L.ly);
    integer(f + "nx", L.nx);
    integer(f + "ny", L.ny);
    integer(f + "spectrum", int64_t(L.spectrum));
    f64(f + "wind_speed", L.wind_speed);
    f64(f + "fetch", L.fetch);
    f64(f + "gamma", L.gamma);
    f64(f + "sigma_a", L.sigma_a);
    f64(f + "sigma_b", L.sigma_b);
    f64(f + "phillips_amplitude", L.phillips_amplitude);
    f64(f + "phillips_cutoff", L.phillips_cutoff);
    f64(f + "phillips_exponent", L.phillips_exponent);
    integer(f + "partials", int64_t(L.partials.size()));
    for (size_t j = 0; j < L.partials.size(); ++j) {
      const PartialSpectrum& p = L.partials[j];
      const std::string g = f + "partials[" + std::to_string(j) + "].";
      f64(g + "peak_frequency", p.peak_frequency);
      f64(g + "significant_wave_height", p.significant_wave_height);
      f64(g + "a", p.a);
      f64(g + "b", p.b);
      f64(g + "c", p.c);
      f64(g + "n", p.n);
      f64(g + "m", p.m);
    }
    integer(f + "spreading", int64_t(L.spreading));
    f64(f + "wind_direction", L.wind_direction);
    integer(f + "dispersion", int64_t(L.dispersion));
    f64(f + "depth", L.depth);
    f64(f + "capillary_length", L.capillary_length);
    f64(f + "gravity", L.gravity);
    integer(f + "seed", int64_t(L.seed));
    f64(f + "drift_x", L.drift_x);
    f64(f + "drift_y", L.drift_y);
    f64(f + "k_min", L.k_min);
    f64(f + "k_max", L.k_max);
  }
  return m;
}

PartialSpectrum partial(double scale) {
  PartialSpectrum p;
  p.peak_frequency = 0.45 * scale, p.significant_wave_height = 1.7 * scale;
  p.a = 2.1 * scale, p.b = 18.5 * scale, p.c = 3.9 * scale, p.n = 4.5 * scale, p.m = 7.25 * scale;
  return p;
}

// Three layers (Multipeak, TMA, Phillips) and every member of the spec, its layers and partials away from
// its default (ocean_params.h); valid, with values that are not round in binary.
TileSpec every_member_set() {
  LayerSpec a;
  a.lx = 300.3, a.ly = 210.7, a.nx = 64, a.ny = 32;
  a.spectrum = SpectrumModel::Multipeak;
  a.wind_speed = 13.1, a.fetch = 55.5e3, a.gamma = 2.7, a.sigma_a = 0.061, a.sigma_b = 0.113;
  a.phillips_amplitude = 2.3e-4, a.phillips_cutoff = 0.051, a.phillips_exponent = 6.1;
  a.partials = {partial(1.0), partial(1.3)};
  a.spreading = SpreadingModel::VonMises;
  a.wind_direction = -0.77;
  a.dispersion = DispersionKind::Combined;
  a.depth = 41.3, a.capillary_length = 3.1e-3, a.gravity = 9.79;
  a.seed = 0x8000000000000123ull;  // the top bit too
  a.drift_x = 0.31, a.drift_y = -0.27, a.k_min = 0.011, a.k_max = 7.3;
  LayerSpec b = a;
  b.lx = 97.1, b.ly = 88.9, b.nx = 16, b.ny = 48;
  b.spectrum = SpectrumModel::Tma;
  b.partials = {partial(0.7)};  // ignored by TMA, kept all the same
  b.spreading = SpreadingModel::Hyperbolic;
  b.dispersion = DispersionKind::Shallow;
  b.seed = 42;
  LayerSpec c = a;
  c.spectrum = SpectrumModel::Phillips;
  c.partials.clear();
  c.spreading = SpreadingModel::Krylov;
  c.dispersion = DispersionKind::Capillary;
  TileSpec spec;
  spec.layers = {a, b, c};
  spec.b_correction = true;
  spec.choppiness = -1.3;
  spec.nx = 96, spec.ny = 80, spec.lx = 150.5, spec.ly = 120.25;
  spec.whitecap_threshold = -0.21, spec.whitecap_decay = 2.9, spec.pixel_scale = 0.37, spec.slope_k_max = 812.5;
  return spec;
}

TEST(TileSpecBytes, EveryMemberRoundTrips) {
  const LimitGate gate{Limits{}};
  const TileSpec spec = every_member_set();
  // Every member differs from its default, so an encoder that skipped one would not restore it.
  TileSpec defaults;
  defaults.layers.assign(spec.layers.size(), LayerSpec{});
  for (size_t i = 0; i < spec.layers.size(); ++i) defaults.layers[i].partials.resize(spec.layers[i].partials.size());
  const Members want = members(spec), unset = members(defaults);
  ASSERT_EQ(want.size(), unset.size());
  auto is_count = [](const std::string& name) {
    return name == "layers" || (name.size() > 9 && name.compare(name.size() - 9, 9, ".partials") == 0);
  };
  for (size_t i = 0; i < want.size(); ++i) {
    if (is_count(want[i].first)) continue;
    EXPECT_NE(want[i].second, unset[i].second) << want[i].first << " is at its default";
  }

  const std::string bytes = encode_tile_spec(spec);
  const Members got = members(decode_tile_spec(bytes, gate, "spec"));
  ASSERT_EQ(got.size(), want.size());
  for (size_t i = 0; i < want.size(); ++i) {
    EXPECT_EQ(got[i].first, want[i].first);
    EXPECT_EQ(got[i].second, want[i].second) << want[i].first;
  }
  EXPECT_EQ(encode_tile_spec(decode_tile_spec(bytes, gate, "spec")), bytes);
}

// The documented layout: 89 bytes of tile, 184 a layer, 56 a partial; the magic, the version and the
// members little-endian at their offsets.
TEST(TileSpecBytes, LayoutIsTheDocumentedOne) {
  TileSpec spec;
  spec.layers.resize(1);
  spec.choppiness = 0.75;  // 0x3FE8000000000000
  spec.nx = 0x0102;
  std::string bytes = encode_tile_spec(spec);
  ASSERT_EQ(bytes.size(), 89u + 184u);
  EXPECT_EQ(bytes.substr(0, 12), std::string("SQOCNSPC\1\0\0\0", 12));
  EXPECT_EQ(bytes.substr(13, 8), std::string("\0\0\0\0\0\0\xE8\x3F", 8));
  EXPECT_EQ(bytes.substr(21, 8), std::string("\x02\x01\0\0\0\0\0\0", 8));
  EXPECT_EQ(bytes.substr(85, 4), std::string("\1\0\0\0", 4));
  spec.layers[0].partials.resize(3);
  EXPECT_EQ(encode_tile_spec(spec).size(), 89u + 184u + 3 * 56u);
}

TEST(TileSpecBytes, BytesThatAreNoSpecAreInvalidArgument) {
  const LimitGate gate{Limits{}};
  const std::string bytes = encode_tile_spec(every_member_set());
  for (size_t n = 0; n < bytes.size(); ++n) {
    const std::string message = expect_error(Code::InvalidArgument, "spec is not an ocean tile spec",
                                             [&] { decode_tile_spec(bytes.substr(0, n), gate, "spec"); });
    EXPECT_NE(message.find(n < 8 ? "magic" : "truncated at byte"), std::string::npos) << message;
  }
  expect_error(Code::InvalidArgument, "(reading spec.layers[1].partials[0].peak_frequency)",
               [&] { decode_tile_spec(bytes.substr(0, 89 + 184 + 2 * 56 + 104), gate, "spec"); });

  std::string wrong = bytes;
  wrong[0] = 'X';
  expect_error(Code::InvalidArgument, "spec is not an ocean tile spec: it does not start with the magic",
               [&] { decode_tile_spec(wrong, gate, "spec"); });
  wrong = bytes;
  wrong[8] = 2;
  expect_error(Code::InvalidArgument, "format version 2; this squalld reads version 1",
               [&] { decode_tile_spec(wrong, gate, "spec"); });
  expect_error(Code::InvalidArgument, "1 bytes follow the last layer",
               [&] { decode_tile_spec(bytes + "x", gate, "spec"); });
  wrong = bytes;
  wrong[12] = 7;
  expect_error(Code::InvalidArgument, "spec.b_correction = 7 must be 0 or 1",
               [&] { decode_tile_spec(wrong, gate, "spec"); });
  wrong = bytes;
  wrong[85] = 0;  // no layers
  expect_error(Code::InvalidArgument, "bytes follow the last layer", [&] { decode_tile_spec(wrong, gate, "spec"); });
  wrong.resize(89);
  expect_error(Code::InvalidArgument, "spec.layers has 0 entries", [&] { decode_tile_spec(wrong, gate, "spec"); });
  wrong = bytes;
  wrong[88] = char(0xFF);  // ~4e9 layers: truncated at the fourth, nothing allocated for the rest
  expect_error(Code::InvalidArgument, "(reading spec.layers[3].lx)", [&] { decode_tile_spec(wrong, gate, "spec"); });
}

// Decoded specs are validated like tile requests (validate_tile), under the caller's path.
TEST(TileSpecBytes, InvalidSpecsAreRejected) {
  const LimitGate gate{Limits{}};
  TileSpec spec = every_member_set();
  spec.layers[1].wind_speed = NAN;
  expect_error(Code::InvalidArgument, "checkpoint.ambient_ocean.layers[1].wind_speed = nan",
               [&] { decode_tile_spec(encode_tile_spec(spec), gate, "checkpoint.ambient_ocean"); });
  spec = every_member_set();
  spec.layers[0].spectrum = SpectrumModel(9);
  expect_error(Code::InvalidArgument, "spec.layers[0].spectrum",
               [&] { decode_tile_spec(encode_tile_spec(spec), gate, "spec"); });
  spec = every_member_set();
  spec.layers[0].partials[1].m = -1;
  expect_error(Code::InvalidArgument, "spec.layers[0].partials[1].m",
               [&] { decode_tile_spec(encode_tile_spec(spec), gate, "spec"); });
  spec = every_member_set();
  spec.slope_k_max = INFINITY;
  expect_error(Code::InvalidArgument, "spec.slope_k_max",
               [&] { decode_tile_spec(encode_tile_spec(spec), gate, "spec"); });
  Limits small;
  small.max_grid_cells = 32 * 32;
  expect_error(Code::ResourceExhausted, "--max-grid-cells",
               [&] { decode_tile_spec(encode_tile_spec(every_member_set()), LimitGate{small}, "spec"); });
}

}  // namespace
}  // namespace squall::ocean
