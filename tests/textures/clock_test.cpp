// Far from time zero: a texture at t0 = 1e8 s advects and turns as it does at t0 = 0. The kernels work in
// float32, whose spacing at 1e8 is 8 s, so the times they see are counted from the step's start and the
// flow noise's turns are reduced on the host in double.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>

#include "support/expect_error.h"
#include "support/test_runtime.h"
#include "support/worst.h"
#include "textures/device_inputs.h"
#include "textures/lagrangian.h"
#include "textures/textures_support.h"

namespace squall::test {
namespace {

using namespace squall::textures;

// A uniform velocity grid whose speed ramps from 0.1 du/s at t0 to 0.3 du/s at t0 + 1 s, in frames `spacing`
// s apart (linear between frames: any spacing is the same ramp), and the last of 11 frames advected on it.
TextureFrame on_a_ramp(double t0, double spacing, Method method) {
  AdvectSpec spec = noise_spec(method, SQUALL_VELOCITY_GRID, {}, 64);
  spec.t0 = t0;
  VelocitySpec& v = spec.velocity;
  v.nx = v.ny = 2;
  v.hx = v.hy = 1;
  for (int k = 0; k * spacing <= 1 + 1e-9; ++k) {
    const float speed = float(0.1 + 0.2 * k * spacing);
    v.frames.push_back({t0 + k * spacing, std::vector<float>(4, speed), std::vector<float>(4, 0)});
  }
  return run(spec, 11).back();
}

// Over tau seconds the ramp carries the window by 0.1 tau + 0.1 tau^2, so naive advection's coordinates are
// u(x) = S (x - that): their largest error.
double worst_ramp_error(double t0, double spacing = 1) {
  const TextureFrame last = on_a_ramp(t0, spacing, Method::Naive);
  const double tau = last.time - t0, shift = 0.1 * tau + 0.1 * tau * tau,
               S = noise_spec(Method::Naive, 0, {}, 64).texture.scale;
  double worst = 0;
  for (int py = 0; py < last.height; ++py) {
    for (int px = 0; px < last.width; ++px) {
      const double x = (px + 0.5) / last.width, y = (py + 0.5) / last.height;
      const size_t k = size_t(px) + size_t(last.width) * py;
      worst = squall::test::worse(worst, std::abs(last.uv_x()[k] - S * (x - shift)), std::abs(last.uv_y()[k] - S * y));
    }
  }
  return worst;
}

TEST(TexturesClock, GridFramesAreBlendedInTimeAtAnyClock) {
  EXPECT_LT(worst_ramp_error(0), 1e-4);
  EXPECT_LT(worst_ramp_error(1e8), 1e-4);  // as one frame (float32 times): off by 0.1 tau^2 S = 0.02
}

// Frames 0.01 s apart and steps of 1/30 s: a step reaches four or five frames, and each part of it is
// interpolated between the two frames around that time. Naive advection's coordinates are exact as with two
// frames; Lagrangian grids' texture is the one they give on the same ramp in two frames. (With the two frames
// around a step's start alone, the later one held, they are off by 1.3e-3 and 1.9e-2.)
TEST(TexturesClock, AStepAcrossSeveralGridFramesFollowsEachOfThem) {
  for (double t0 : {0.0, 1e8}) {
    EXPECT_LT(worst_ramp_error(t0, 0.01), 1e-4) << t0;
    const double lagrangian =
        max_abs_difference(on_a_ramp(t0, 0.01, Method::LagrangianGrids), on_a_ramp(t0, 1, Method::LagrangianGrids), 0);
    EXPECT_LT(lagrangian, 1e-4) << t0;
  }
}

// A step interpolates between SQUALL_VELOCITY_WINDOW (8) frames at most: seven frames within less than
// one step, with a frame before and one after them, are refused, naming the last of the seven. Seven that
// end the list need one frame besides (after the last the field is held), and are taken.
TEST(TexturesValidation, MoreGridFramesThanAStepReachesAreRefused) {
  AdvectSpec spec = noise_spec(Method::LagrangianGrids, SQUALL_VELOCITY_GRID, {}, 64);
  spec.dt = 0.1;
  VelocitySpec& v = spec.velocity;
  v.nx = v.ny = 2;
  v.hx = v.hy = 1;
  for (int k = 0; k < 12; ++k) v.frames.push_back({0.017 * k, std::vector<float>(4, 0.1f), std::vector<float>(4)});
  texture_engine().validate(spec, "spec");  // six spacings of 0.017 s: 0.102 s, past a step of 0.1 s
  v.frames[9].time = v.frames[8].time + 0.0145;
  expect_error(Code::InvalidArgument,
               "spec.velocity.grid.frames[9].time = 0.1505 must be at least 0.1 s after "
               "frames[3].time = 0.051",
               [&] { texture_engine().validate(spec, "spec"); });
  spec.method = Method::Naive;
  spec.substeps = 2;  // Eulerian steps of dt / substeps
  texture_engine().validate(spec, "spec");
  spec.method = Method::LagrangianGrids;
  v.frames.resize(10);  // frames[3..9], 0.0995 s apart, end the list
  texture_engine().validate(spec, "spec");
}

// Flow noise of one band at spin 2 pi rad/s turns by a whole number of turns in 1e8 s: the window at
// 1e8 + 0.25 s is the window at 0.25 s.
TEST(TexturesClock, FlowNoiseTurnsAtAnyClock) {
  AdvectSpec spec = noise_spec(Method::Naive, SQUALL_VELOCITY_UNIFORM, {}, 64);
  spec.texture.spin = 2 * M_PI;
  auto window_at = [&](double t0) {
    spec.t0 = t0;
    return texture_engine().window(spec);
  };
  const TextureFrame quarter = window_at(0.25);
  EXPECT_GT(max_abs_difference(quarter, window_at(0.5), 0), 0.1);  // the noise turns: the test can tell
  EXPECT_LT(max_abs_difference(quarter, window_at(1e8 + 0.25), 0), 1e-4);
}

// Steering the spin at t = 10 s turns the bands on from where they are, at the new rate: no jump of
// (new - old spin) t, which at t = 1e8 s would be any angle at all.
TEST(TexturesClock, ASteeredSpinTurnsOnFromWhereTheBandsAre) {
  AdvectSpec spec = noise_spec(Method::Naive, SQUALL_VELOCITY_UNIFORM, {}, 64);
  spec.texture.bands = 2;
  spec.texture.spin = 0.5;
  const DeviceInputs inputs(runtime(), spec, ReferenceStats{});
  spec.texture.spin = 2;
  const std::shared_ptr<const DeviceInputs> steered = inputs.steered(runtime(), spec, 10);
  for (int c = 0; c < 2; ++c) {
    const double rate = std::exp2(2.0 * c / 3);
    EXPECT_NEAR(steered->texture(10).turn[c], std::fmod(rate * 0.5 * 10, 2 * M_PI), 1e-5);
    EXPECT_NEAR(steered->texture(11).turn[c], std::fmod(rate * (0.5 * 10 + 2 * 1), 2 * M_PI), 1e-5);
  }
}

TEST(TexturesClock, TimesAndSpinsPastTheirRangeAreRefusedNamingTheField) {
  AdvectSpec spec = noise_spec(Method::Naive, SQUALL_VELOCITY_UNIFORM, {}, 64);
  spec.frames = 1;
  spec.t0 = -2e9;
  expect_error(Code::InvalidArgument, "spec.t0 = -2e+09", [&] { texture_engine().validate(spec, "spec"); });
  spec.t0 = 1e9;
  spec.dt = 5e-8;  // t0 + dt is 1e9 + 0 or one step of 1.2e-7 s: frames double cannot tell apart
  expect_error(Code::InvalidArgument, "spec.dt = 5e-08 s at times up to 1e+09 s",
               [&] { texture_engine().validate(spec, "spec"); });
  spec.dt = 1e-3;
  {  // a steered stream: its frames go on from the time it reached, not from t0
    AdvectSpec steered = spec;
    steered.t0 = 0;
    steered.dt = 1e-11;
    validate_clock(steered, "spec");
    expect_error(Code::InvalidArgument, "spec.dt = 1e-11 s at times up to 1000000 s",
                 [&] { validate_clock(steered, "spec", 1e6); });
  }
  spec.texture.spin = 2e6;
  expect_error(Code::InvalidArgument, "spec.texture.noise.spin", [&] { texture_engine().validate(spec, "spec"); });
  spec.texture.spin = 0;
  spec.velocity.kind = SQUALL_VELOCITY_GRID;
  spec.velocity.nx = spec.velocity.ny = 2;
  spec.velocity.hx = spec.velocity.hy = 1;
  for (double time : {0.0, 2e10}) spec.velocity.frames.push_back({time, std::vector<float>(4), std::vector<float>(4)});
  expect_error(Code::InvalidArgument, ".frames[1].time", [&] { texture_engine().validate(spec, "spec"); });
}

// Values whose blends overflow float32 on the device, and a latency that divides by zero, are refused by
// name: a final scale of 1e308 or LUT entries of +-3e38 made every plane infinite, image pixels of +-3e38 NaN,
// a latency of 1e-310 s NaN.
TEST(TexturesValidation, ValuesThatOverflowFloat32AreRefusedNamingTheField) {
  const AdvectSpec good = noise_spec(Method::EulerianMultilayer, SQUALL_VELOCITY_UNIFORM, {}, 64);
  auto expect = [&](const char* field, auto change) {
    AdvectSpec spec = good;
    change(spec);
    expect_error(Code::InvalidArgument, field, [&] { texture_engine().validate(spec, "spec"); });
  };
  expect("spec.texture.final_scale = 1e+308", [](AdvectSpec& s) { s.texture.final_scale = 1e308; });
  expect("spec.eulerian.latencies[0] = 1e-310", [](AdvectSpec& s) { s.eulerian.latencies[0] = 1e-310; });
  expect("spec.texture.lut.table", [](AdvectSpec& s) {
    s.texture.final_function = SQUALL_FINAL_LUT;
    s.texture.lut.table = {-3e38f, 3e38f};
  });
  expect("spec.texture.lut.lut_max", [](AdvectSpec& s) {
    s.texture.final_function = SQUALL_FINAL_LUT;
    s.texture.lut.table = {0, 1};
    s.texture.lut.lut_min = 1;
    s.texture.lut.lut_max = 1 + 1e-12;  // the same float
  });
  expect("spec.texture.image.pixels", [](AdvectSpec& s) {
    s.texture.kind = SQUALL_TEXTURE_IMAGE;
    s.texture.width = s.texture.height = s.texture.channels = 1;
    s.texture.pixels = {3e38f};
  });
  texture_engine().validate(good, "spec");
}

// A substep that turns the field by more than RK4 keeps stable is refused naming substeps: a rotation of
// 1e5 rad/s in one substep of 1/30 s carried the Lagrangian grids to infinity and the planes to NaN.
TEST(TexturesValidation, SubstepsThatCannotFollowTheFieldAreRefused) {
  AdvectSpec spec = noise_spec(Method::LagrangianGrids, SQUALL_VELOCITY_ROTATION, {1e5, 0.5, 0.5}, 32);
  spec.dt = 1.0 / 30;
  spec.substeps = 64;  // 52 rad per substep
  expect_error(Code::InvalidArgument, "spec.substeps = 64: the velocity field turns by ",
               [&] { texture_engine().validate(spec, "spec"); });
  spec.velocity.params[0] = 50;  // 1.7 rad at 1 substep
  spec.substeps = 1;
  texture_engine().validate(spec, "spec");
  // The same rule for a grid: a rotation of 100 rad/s sampled on 64 x 64 nodes, 3.3 rad at 1 substep.
  const int n = 64;
  const double omega = 100, h = 1.0 / (n - 1);
  spec.velocity = VelocitySpec{};
  spec.velocity.kind = SQUALL_VELOCITY_GRID;
  spec.velocity.nx = spec.velocity.ny = n;
  spec.velocity.hx = spec.velocity.hy = h;
  VelocityFrame frame;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      frame.u.push_back(float(-omega * (j * h - 0.5)));
      frame.v.push_back(float(omega * (i * h - 0.5)));
    }
  spec.velocity.frames = {frame};
  expect_error(Code::InvalidArgument, "spec.substeps = 1: the velocity field turns by 3.33",
               [&] { texture_engine().validate(spec, "spec"); });
  spec.substeps = 2;
  texture_engine().validate(spec, "spec");
  // A still grid whose solid columns i = 0, 1 hold a speed of 50 du/s. Column 0's cells carry no texel; the
  // cells between columns 1 and 2 carry the fluid up to half a cell from column 2, at their bilinear speed,
  // whose gradient of 3150 /s turns 52 rad per substep.
  std::fill(frame.u.begin(), frame.u.end(), 0.0f);
  std::fill(frame.v.begin(), frame.v.end(), 0.0f);
  spec.velocity.mask.assign(size_t(n) * n, 1);
  for (int j = 0; j < n; ++j) {
    spec.velocity.mask[size_t(j) * n] = spec.velocity.mask[size_t(j) * n + 1] = 0;
    frame.u[size_t(j) * n] = 50;
  }
  spec.velocity.frames = {frame};
  texture_engine().validate(spec, "spec");
  for (int j = 0; j < n; ++j) spec.velocity.frames[0].u[size_t(j) * n + 1] = 50;
  expect_error(Code::InvalidArgument, "spec.substeps = 2: the velocity field turns by 52",
               [&] { texture_engine().validate(spec, "spec"); });
  spec.velocity.extrapolation = Extrapolation::PushPull;  // the solid nodes take the still fluid's speed
  texture_engine().validate(spec, "spec");
}

// The reconstruction's tile lists are indexed by cl_int: an output and a d whose grids could meet more tiles
// than that in all (lagrangian_tile_bound) are refused, which only a --max-grid-cells far past its default
// lets through to this check.
TEST(TexturesValidation, TileListsPastClIntAreRefused) {
  LimitGate gate{Limits{.max_grid_cells = uint64_t(1) << 40}};
  TextureEngine engine(runtime(), gate);
  AdvectSpec spec = noise_spec(Method::LagrangianGrids, SQUALL_VELOCITY_UNIFORM, {}, 131072);
  spec.lagrangian.d = 0.005;
  ASSERT_GT(lagrangian_tile_bound(spec.lagrangian, spec.output), uint64_t(INT32_MAX));
  expect_error(Code::ResourceExhausted, "spec.lagrangian.d = 0.005 over an output of 131072 x 131072 pixels",
               [&] { engine.validate(spec, "spec"); });
  spec.output.width = spec.output.height = 4096;
  engine.validate(spec, "spec");
}

// Lagrangian grid vertices are placed in float32 as pixels are: d = 0.3 with beta = 0.05 and 16 vertices a
// side puts them 0.041 du apart, where float32's step at x = 1e6 is 0.0625 (they coincide, and every grid
// was killed as folded on its first frame); the same grids near the origin run.
TEST(TexturesValidation, LagrangianVerticesFinerThanFloat32PlacesThemAreRefused) {
  AdvectSpec spec = noise_spec(Method::LagrangianGrids, SQUALL_VELOCITY_UNIFORM, {}, 32);
  spec.output = {32, 32, 1e6, 1e6, 1e6 + 64, 1e6 + 64};
  spec.lagrangian.d = 0.3;
  spec.lagrangian.beta = 0.05;
  spec.lagrangian.grid_res = 16;
  expect_error(Code::InvalidArgument, "spec.lagrangian.d: grid vertices of 0.041",
               [&] { texture_engine().validate(spec, "spec"); });
  spec.output = {32, 32, 0, 0, 64, 64};
  texture_engine().validate(spec, "spec");
}

// Grids of any size cover the pixels: over a region 1e-8 du wide with d = 2.5e-10 the triangles' areas are
// below 1e-20 du^2 (an absolute threshold of 1e-20 left every pixel uncovered), as at d = 0.025 over 1 du.
TEST(TexturesLagrangian, TinyGridsCoverEveryPixel) {
  for (double extent : {1e-8, 1.0}) {
    AdvectSpec spec = noise_spec(Method::LagrangianGrids, SQUALL_VELOCITY_UNIFORM, {}, 32);
    spec.output = {32, 32, 0, 0, extent, extent};
    spec.lagrangian.d = extent / 40;
    texture_engine().validate(spec, "spec");
    const TextureFrame frame = texture_engine().start(spec)->next();
    EXPECT_EQ(frame.stats.uncovered, 0) << "a region " << extent << " du wide";
  }
}

// Pixels (and Eulerian nodes) finer than float32 places at the region's coordinates: a 1 du region of 64
// pixels at x = 1e6 came out flat. The same region at x = 1e3 is accepted.
TEST(TexturesValidation, PixelsFinerThanFloat32PlacesThemAreRefused) {
  AdvectSpec spec = noise_spec(Method::EulerianMultilayer, SQUALL_VELOCITY_UNIFORM, {}, 64);
  spec.output.x0 = 1e6;
  spec.output.x1 = 1e6 + 1;
  expect_error(Code::InvalidArgument, "spec.output: pixels of ", [&] { texture_engine().validate(spec, "spec"); });
  spec.output.x0 = 1e3;
  spec.output.x1 = 1e3 + 1;
  texture_engine().validate(spec, "spec");
  spec.output = {1024, 64, 0, 0, 1, 1e4};  // each axis against its own coordinates: fine pixels near x = 0
  texture_engine().validate(spec, "spec");
  spec.velocity.kind = SQUALL_VELOCITY_GRID;  // a spacing that float32 rounds to 0
  spec.velocity.nx = spec.velocity.ny = 2;
  spec.velocity.hx = 1e-50;
  spec.velocity.hy = 1;
  spec.velocity.frames = {{0.0, std::vector<float>(4), std::vector<float>(4)}};
  expect_error(Code::InvalidArgument, "spec.velocity.grid.spacing.x = 1e-50",
               [&] { texture_engine().validate(spec, "spec"); });
  // Eulerian nodes too: 4096 over 1.25 du at x = 1e4 are 3e-4 du apart, where float32's step is 1e-3 (their
  // strain and vorticity read x +- h as x); 64 of them are as far apart as the pixels.
  spec = noise_spec(Method::EulerianMultilayer, SQUALL_VELOCITY_UNIFORM, {}, 64);
  spec.output = {64, 64, 1e4, 0, 1e4 + 1.25, 1};
  spec.eulerian.grid_nx = 4096;
  expect_error(Code::InvalidArgument, "spec.eulerian.grid_nx: nodes of 0.000305",
               [&] { texture_engine().validate(spec, "spec"); });
  spec.eulerian.grid_nx = 64;
  texture_engine().validate(spec, "spec");
}

}  // namespace
}  // namespace squall::test
