// Bad input: InvalidArgument (or ResourceExhausted for the grid limit) naming the field.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>

#include "common/error.h"
#include "ocean_test_util.h"

#include "support/expect_error.h"

namespace squall::ocean {
namespace {

void expect_rejected(const std::function<void(TileSpec&)>& change, const std::string& field,
                     Code code = Code::InvalidArgument) {
  TileSpec spec = test::single(SpectrumModel::Jonswap, SpreadingModel::Mitsuyasu, 32, 100);
  change(spec);
  squall::test::expect_error(code, field, [&] { test::engine().validate(spec); });
}

TEST(OceanValidation, BadFieldsAreNamed) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  expect_rejected([&](TileSpec& s) { s.layers[0].wind_speed = nan; }, "layers[0].wind_speed");
  expect_rejected([&](TileSpec& s) { s.layers[0].wind_speed = -3; }, "layers[0].wind_speed");
  expect_rejected([&](TileSpec& s) { s.layers[0].fetch = -1; }, "layers[0].fetch");
  expect_rejected([&](TileSpec& s) { s.layers[0].nx = 0; }, "layers[0].nx");
  expect_rejected([&](TileSpec& s) { s.layers[0].ny = -4; }, "layers[0].ny");
  expect_rejected([&](TileSpec& s) { s.layers[0].nx = 33; }, "layers[0].nx");
  expect_rejected([&](TileSpec& s) { s.layers[0].nx = s.layers[0].ny = 1 << 16; }, "layers[0].nx",
                  Code::ResourceExhausted);
  expect_rejected([&](TileSpec& s) { s.layers[0].spectrum = SpectrumModel(9); }, "layers[0].spectrum");
  expect_rejected([&](TileSpec& s) { s.layers[0].spreading = SpreadingModel(-1); }, "layers[0].spreading");
  expect_rejected([&](TileSpec& s) { s.layers[0].dispersion = DispersionKind(4); }, "layers[0].dispersion");
  expect_rejected([&](TileSpec& s) { s.layers[0].lx = 0; }, "layers[0].lx");
  expect_rejected([&](TileSpec& s) { s.layers[0].depth = nan; }, "layers[0].depth");
  expect_rejected([&](TileSpec& s) { s.layers[0].gamma = 0.5; }, "layers[0].gamma");
  expect_rejected([&](TileSpec& s) { s.layers[0].drift_x = INFINITY; }, "layers[0].drift_x");
  expect_rejected(
      [&](TileSpec& s) {
        s.layers.push_back(s.layers[0]);
        s.layers[1].gravity = 0;
      },
      "layers[1].gravity");
  expect_rejected([&](TileSpec& s) { s.layers[0].spectrum = SpectrumModel::Multipeak; }, "layers[0].partials");
  expect_rejected(
      [&](TileSpec& s) {
        s.layers[0].spectrum = SpectrumModel::Multipeak;
        s.layers[0].partials.push_back(PartialSpectrum{});
        s.layers[0].partials[0].peak_frequency = -1;
      },
      "layers[0].partials[0].peak_frequency");
  expect_rejected([&](TileSpec& s) { s.layers.clear(); }, "layers");
  expect_rejected([&](TileSpec& s) { s.choppiness = nan; }, "choppiness");
  expect_rejected([&](TileSpec& s) { s.whitecap_decay = 0; }, "whitecap_decay");
  expect_rejected(
      [&](TileSpec& s) {
        s.nx = 64;
        s.ny = 0;
        s.lx = s.ly = 10;
      },
      "output.ny");
  expect_rejected(
      [&](TileSpec& s) {
        s.nx = s.ny = 64;
        s.lx = -1;
        s.ly = 10;
      },
      "output.lx");
  // a small gate: the limit in force is the daemon's
  TileSpec spec = test::single(SpectrumModel::Jonswap, SpreadingModel::Mitsuyasu, 64, 100);
  Limits limits;
  limits.max_grid_cells = 1024;
  LimitGate gate(limits);
  EXPECT_THROW(test::engine().validate(spec, gate), Error);
}

TEST(OceanValidation, TileRejectsBadOutputsTimeAndBackwardsStream) {
  TileSpec spec = test::single(SpectrumModel::Jonswap, SpreadingModel::Mitsuyasu, 32, 100);
  EXPECT_THROW(test::engine().tile(spec, 0, 0), Error);
  EXPECT_THROW(test::engine().tile(spec, 0, 1u << 9), Error);
  EXPECT_THROW(test::engine().tile(spec, std::nan(""), Height), Error);
  WhitecapState state;
  test::engine().tile(spec, 5, Whitecaps, &state);
  squall::test::expect_error(Code::InvalidArgument, "t = ", [&] { test::engine().tile(spec, 4, Whitecaps, &state); });
  TileSpec bad = spec;
  bad.layers[0].wind_speed = -1;
  EXPECT_THROW(test::engine().sample(bad, 0, {{1, 2}}, false), Error);
  EXPECT_THROW(test::engine().sample(spec, 0, {{std::nan(""), 2}}, false), Error);
  // the engine keeps serving after bad input
  EXPECT_EQ(test::engine().tile(spec, 1, Height).height.size(), 32u * 32u);
}

// The device holds a partial's shape and scale in float32: a c that rounds to 0 there, or a scale past its
// range (Hs 100 m carried by c = 1e-29 alone: about 4.6e32), is refused naming the partial, not turned into a
// flat or NaN sea.
TEST(OceanValidation, MultipeakPartialsPastFloat32AreRefusedByName) {
  TileSpec spec = test::single(SpectrumModel::Multipeak, SpreadingModel::VonMises, 32, 100);
  spec.layers[0].partials = {{1.0, 100.0, 0.0, 22.2222, 1e-29, 5, 8}};
  squall::test::expect_error(Code::InvalidArgument, "layers[0].partials[0]: its shape's scale",
                             [&] { test::engine().validate(spec, LimitGate{Limits{}}); });
  spec.layers[0].partials[0].c = 1e-35;
  squall::test::expect_error(Code::InvalidArgument, "layers[0].partials[0].c = 1e-35",
                             [&] { test::engine().validate(spec, LimitGate{Limits{}}); });
  spec.layers[0].partials[0].c = 1e-3;
  test::engine().validate(spec, LimitGate{Limits{}});
}

// A partial is normalized to its Hs over w / w_p in [0.02, 2000]: a shape with its energy elsewhere is refused
// by name, before its low modes (r^-20 at r = 0.008 is past float) turn the tile into NaN.
TEST(OceanValidation, MultipeakPartialsWithEnergyOutsideTheirRangeAreRefusedByName) {
  TileSpec spec = test::single(SpectrumModel::Multipeak, SpreadingModel::Isotropic, 32, 100);
  auto refused = [&](PartialSpectrum p, const char* why) {
    spec.layers[0].partials = {p};
    const std::string message = squall::test::expect_error(
        Code::InvalidArgument,
        "layers[0].partials[0]: its shape (a = ", [&] { test::engine().validate(spec, LimitGate{Limits{}}); });
    EXPECT_NE(message.find(why), std::string::npos) << message;
  };
  PartialSpectrum low;  // the hump peaks at r = (7.987 m / n)^(1/m) = 1e-14
  low.peak_frequency = 100;
  low.significant_wave_height = 4;
  low.n = 20;
  low.m = 0.1;
  refused(low, "of its energy outside");
  PartialSpectrum heavy;  // r^-1.2 past 2000: most of it outside
  heavy.n = 1.2;
  refused(heavy, "of its energy outside");
  PartialSpectrum flat;  // a Gaussian of b = 0: a constant
  flat.b = 0;
  refused(flat, "energy without bound");
  // A hump of c = 1, n = 100, m = 1 peaks at e^152.7 (r = 0.08), past float32, and its scale, 1.4e-66, is 0 there:
  // the device made a flat sea of a partial of Hs = 1 m.
  PartialSpectrum steep;
  steep.peak_frequency = 10;
  steep.significant_wave_height = 1;
  steep.n = 100;
  steep.m = 1;
  steep.c = 1;
  spec.layers[0].partials = {steep};
  squall::test::expect_error(Code::InvalidArgument,
                             "layers[0].partials[0]: its shape's hump c r^-n exp(-7.987 r^-m) "
                             "peaks at e^152.7",
                             [&] { test::engine().validate(spec, LimitGate{Limits{}}); });
  spec.layers[0].partials = {PartialSpectrum{}};  // eq 26's shape
  test::engine().validate(spec, LimitGate{Limits{}});
  spec.layers[0].partials[0].b = 3;  // a broad peak: a thousandth of its energy below 0.02
  test::engine().validate(spec, LimitGate{Limits{}});
}

// Krylov's spread follows the mean frequency m1 / m0, which a hump's tail r^-n leaves infinite for n <= 2
// (a shape the normalization range accepts: c = 1, n = 2 has 0.07% of its energy outside it).
TEST(OceanValidation, AKrylovSeaWhoseMeanFrequencyDivergesIsRefusedByName) {
  TileSpec spec = test::single(SpectrumModel::Multipeak, SpreadingModel::Krylov, 32, 100);
  PartialSpectrum tail;
  tail.a = 0, tail.c = 1, tail.n = 2, tail.m = 8;
  spec.layers[0].partials = {tail};
  squall::test::expect_error(Code::InvalidArgument, "layers[0].partials[0].n = 2 must be above 2 where c > 0",
                             [&] { test::engine().validate(spec, LimitGate{Limits{}}); });
  spec.layers[0].spreading = SpreadingModel::Mitsuyasu;  // no mean frequency needed
  spec.layers[0].wind_speed = 10;
  test::engine().validate(spec, LimitGate{Limits{}});
  spec.layers[0].spreading = SpreadingModel::Krylov;
  spec.layers[0].partials[0].n = 3;
  test::engine().validate(spec, LimitGate{Limits{}});
}

}  // namespace
}  // namespace squall::ocean
