// The final function LUT driven by a scalar field (Q. Yu, F. Neyret, E. Bruneton, N. Holzschuch,
// "Lagrangian Texture Advection", IEEE TVCG 2011, sec. 3.2, the fire example):
// T = LUT(s(x) + final_scale sum_j 2^-j g(a_j)), every output pixel checked against the same formula
// evaluated on the host in double precision (bilinear image and scalar field, linear table).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "support/expect_error.h"
#include "support/test_runtime.h"
#include "support/worst.h"
#include "textures/textures_support.h"

namespace squall::test {
namespace {

using namespace squall::textures;
constexpr double kPi = 3.14159265358979323846;

// g of the band shapings (fields.h).
double shaped(int shape, double a) {
  if (shape == SQUALL_FINAL_TURBULENCE) return std::abs(2 * a - 1);
  if (shape == SQUALL_FINAL_RIDGED) return 1 - std::abs(2 * a - 1);
  return a;
}

// Channel c of LUT(v): linear between entries, clamped at the ends of [lut_min, lut_max].
double lut_at(const FinalLookupSpec& l, double v, int c) {
  const int n = int(l.table.size()) / l.channels;
  double x = std::clamp((v - l.lut_min) / (l.lut_max - l.lut_min) * (n - 1), 0.0, double(n - 1));
  int k = std::min(int(std::floor(x)), n - 2);
  double f = x - k;
  return (1 - f) * l.table[size_t(k * l.channels + c)] + f * l.table[size_t((k + 1) * l.channels + c)];
}

// s(x, y): bilinear between the nodes, clamped to the edge nodes; 0 without a field.
double scalar_at(const ScalarGridSpec& g, double x, double y) {
  if (g.values.empty()) return 0;
  double gx = std::clamp((x - g.origin_x) / g.hx, 0.0, double(g.nx - 1));
  double gy = std::clamp((y - g.origin_y) / g.hy, 0.0, double(g.ny - 1));
  int i = std::min(int(gx), g.nx - 2), j = std::min(int(gy), g.ny - 2);
  double s = gx - i, r = gy - j;
  auto v = [&](int a, int b) { return double(g.values[size_t(a + g.nx * b)]); };
  return (1 - r) * ((1 - s) * v(i, j) + s * v(i + 1, j)) + r * ((1 - s) * v(i, j + 1) + s * v(i + 1, j + 1));
}

// Plane 0 of an image texture, bilinear with wrap at u (periods), texel centres at (i + 0.5) / width.
double image_at(const TextureSpec& t, double ux, double uy) {
  double x = (ux - std::floor(ux)) * t.width - 0.5, y = (uy - std::floor(uy)) * t.height - 0.5;
  double fx = std::floor(x), fy = std::floor(y);
  int i0 = (int(fx) + t.width) % t.width, j0 = (int(fy) + t.height) % t.height;
  int i1 = (i0 + 1) % t.width, j1 = (j0 + 1) % t.height;
  auto p = [&](int i, int j) { return double(t.pixels[size_t(i + t.width * j)]); };
  double s = x - fx, r = y - fy;
  return (1 - r) * ((1 - s) * p(i0, j0) + s * p(i1, j0)) + r * ((1 - s) * p(i0, j1) + s * p(i1, j1));
}

// Output c of the final function at pixel (px, py) of a one-channel texture whose blended channel is a.
double expected(const AdvectSpec& spec, int px, int py, double a, int c) {
  const OutputSpec& o = spec.output;
  double x = o.x0 + (px + 0.5) * (o.x1 - o.x0) / o.width, y = o.y0 + (py + 0.5) * (o.y1 - o.y0) / o.height;
  const FinalLookupSpec& l = spec.texture.lut;
  return lut_at(l, scalar_at(l.field, x, y) + spec.texture.final_scale * shaped(l.band_shape, a), c);
}

// A 3-channel LUT of 5 entries over [-0.5, 2] (not linear in its input: a colour ramp).
FinalLookupSpec colour_lut() {
  FinalLookupSpec l;
  l.channels = 3;
  for (int k = 0; k < 5; ++k) {
    l.table.push_back(float(k * k / 16.0));
    l.table.push_back(float(1 - k / 4.0));
    l.table.push_back(float(0.5 + 0.5 * std::sin(1.7 * k)));
  }
  l.lut_min = -0.5;
  l.lut_max = 2.0;
  return l;
}

// Zero velocity, a 24 x 20 one-channel smooth tileable image at 2 periods per du, a 5 x 4 scalar field
// covering part of the domain (clamped elsewhere), and colour_lut(): 64 x 64 pixels over the unit square.
AdvectSpec static_lut_spec(Method method) {
  AdvectSpec spec = noise_spec(method, SQUALL_VELOCITY_UNIFORM, {}, 64);
  TextureSpec& t = spec.texture;
  t.kind = SQUALL_TEXTURE_IMAGE;
  t.width = 24;
  t.height = 20;
  t.channels = 1;
  for (int j = 0; j < t.height; ++j)
    for (int i = 0; i < t.width; ++i)
      t.pixels.push_back(float(0.5 + 0.45 * std::sin(2 * kPi * i / t.width) * std::cos(4 * kPi * j / t.height)));
  t.final_function = SQUALL_FINAL_LUT;
  t.final_scale = 0.8;
  t.lut = colour_lut();
  ScalarGridSpec& s = t.lut.field;
  s.nx = 5;
  s.ny = 4;
  s.origin_x = 0.1;
  s.origin_y = -0.05;
  s.hx = 0.2;
  s.hy = 0.3;
  for (int j = 0; j < s.ny; ++j)
    for (int i = 0; i < s.nx; ++i) s.values.push_back(float(0.3 * i - 0.2 * j + 0.1 * ((i * j) % 3)));
  spec.eulerian.grid_nx = spec.eulerian.grid_ny = 33;
  spec.lagrangian.patch_origin = PatchOrigin::Window;
  spec.lagrangian.blend = Blend::Normalized;  // eq. 3: coinciding samples average to the input
  return spec;
}

// The largest |final plane c - LUT(s(x) + final_scale g(R(S x)))| over the frame's pixels and channels.
double static_error(const AdvectSpec& spec, const TextureFrame& frame) {
  double worst = 0;
  const OutputSpec& o = spec.output;
  for (int py = 0; py < frame.height; ++py) {
    for (int px = 0; px < frame.width; ++px) {
      double x = o.x0 + (px + 0.5) * (o.x1 - o.x0) / o.width, y = o.y0 + (py + 0.5) * (o.y1 - o.y0) / o.height;
      double a = image_at(spec.texture, spec.texture.scale * x, spec.texture.scale * y);
      for (int c = 0; c < frame.final_planes; ++c) {
        double got = frame.plane(c)[px + frame.width * py];
        worst = squall::test::worse(worst, std::abs(got - expected(spec, px, py, a, c)));
      }
    }
  }
  return worst;
}

TEST(TexturesFinalLut, StaticImageEqualsTheHostLookupForEachMethodAndShaping) {
  struct Case {
    Method method;
    EulerianBlend blend;
    int shape;
  };
  const Case cases[] = {{Method::EulerianMultilayer, EulerianBlend::Octave, SQUALL_FINAL_RIDGED},
                        {Method::EulerianMultilayer, EulerianBlend::Final, SQUALL_FINAL_TURBULENCE},
                        {Method::LagrangianGrids, EulerianBlend::Octave, SQUALL_FINAL_RIDGED},
                        {Method::LagrangianGrids, EulerianBlend::Octave, SQUALL_FINAL_SUM_BANDS}};
  for (const Case& k : cases) {
    AdvectSpec spec = static_lut_spec(k.method);
    spec.eulerian.blend = k.blend;
    spec.texture.lut.band_shape = k.shape;
    for (const TextureFrame& frame : run(spec, 2)) {
      ASSERT_EQ(frame.final_planes, 3);
      ASSERT_EQ(frame.raw_planes, 1);
      double error = static_error(spec, frame);
      EXPECT_LT(error, 1e-4) << "method " << int(spec.method) << " blend " << int(k.blend) << " shape " << k.shape
                             << " frame " << frame.index;
      std::printf("[ lut ] method %d blend %d shape %d frame %d: max |T - host| = %.3g\n", int(spec.method),
                  int(k.blend), k.shape, frame.index, error);
    }
  }
}

// The reference window (texture_window) applies the same F.
TEST(TexturesFinalLut, WindowEqualsTheHostLookup) {
  AdvectSpec spec = static_lut_spec(Method::Naive);
  TextureFrame frame = texture_engine().window(spec);
  ASSERT_EQ(frame.final_planes, 3);
  EXPECT_LT(static_error(spec, frame), 1e-4);
}

// Moving noise carried by the Lagrangian grids (random patches, eq. 4), under a scalar field that is 0 on
// the left third of the domain and 1 on the right third: each pixel's F equals the host's LUT of
// s(x) + final_scale g(R') with R' the frame's raw plane, and the two thirds' means differ as the table says.
TEST(TexturesFinalLut, ScalarFieldShiftsTheLookup) {
  AdvectSpec spec = noise_spec(Method::LagrangianGrids, SQUALL_VELOCITY_UNIFORM, {0.2, 0.1}, 96);
  TextureSpec& t = spec.texture;
  t.final_function = SQUALL_FINAL_LUT;
  t.final_scale = 0.5;
  t.lut.channels = 1;
  t.lut.table = {0.0f, 1.0f, 0.1f, 0.6f};  // over [0, 1.5]: up, down, up
  t.lut.lut_max = 1.5;
  t.lut.band_shape = SQUALL_FINAL_RIDGED;
  t.lut.field = {4, 2, 0, 0, 1.0 / 3, 1, {0, 0, 1, 1, 0, 0, 1, 1}};
  const TextureFrame frame = run(spec, 4).back();
  ASSERT_EQ(frame.final_planes, 1);
  const float* final = frame.plane(0);
  const float* raw = frame.plane(1);
  double worst = 0, got[2] = {0, 0}, want[2] = {0, 0}, without_s[2] = {0, 0};
  int count[2] = {0, 0};
  for (int py = 0; py < frame.height; ++py) {
    for (int px = 0; px < frame.width; ++px) {
      const size_t k = size_t(px + frame.width * py);
      const double value = expected(spec, px, py, raw[k], 0);
      worst = squall::test::worse(worst, std::abs(final[k] - value));
      const int region = px < frame.width / 3 ? 0 : px >= frame.width - frame.width / 3 ? 1 : -1;
      if (region < 0) continue;
      got[region] += final[k];
      want[region] += value;
      without_s[region] += lut_at(t.lut, t.final_scale * shaped(t.lut.band_shape, raw[k]), 0);
      ++count[region];
    }
  }
  for (int r = 0; r < 2; ++r) {
    got[r] /= count[r];
    want[r] /= count[r];
    without_s[r] /= count[r];
  }
  std::printf(
      "[ lut ] max |T - host| = %.3g; mean T: s = 0 third %.4f (host %.4f), s = 1 third %.4f (host %.4f, "
      "%.4f if s were ignored)\n",
      worst, got[0], want[0], got[1], want[1], without_s[1]);
  EXPECT_LT(worst, 1e-4);
  EXPECT_NEAR(got[0], want[0], 1e-5);
  EXPECT_NEAR(got[1], want[1], 1e-5);
  EXPECT_NEAR(got[0], without_s[0], 1e-5);  // s = 0 there
  EXPECT_GT(std::abs(got[1] - without_s[1]), 0.1);
  EXPECT_GT(std::abs(got[1] - got[0]), 0.1);
}

TEST(TexturesFinalLut, BadLookupsAreRejectedNamingTheField) {
  struct Case {
    void (*edit)(FinalLookupSpec&);
    std::string needle;
  };
  const Case cases[] = {
      {[](FinalLookupSpec& l) { l.table.resize(3); },
       "spec.texture.lut.table size / channels = 1 must be in [2, 4096]"},
      {[](FinalLookupSpec& l) { l.table.resize(4097 * 3, 0.5f); }, "spec.texture.lut.table size / channels = 4097"},
      {[](FinalLookupSpec& l) { l.table.pop_back(); }, "spec.texture.lut.table size = 14 must be a multiple of"},
      {[](FinalLookupSpec& l) { l.table[4] = NAN; }, "spec.texture.lut.table[4] = nan must be finite"},
      {[](FinalLookupSpec& l) { l.channels = 5; }, "spec.texture.lut.channels = 5 must be in [1, 4]"},
      {[](FinalLookupSpec& l) { l.lut_max = l.lut_min; },
       "spec.texture.lut.lut_max = -0.5 must be finite and in (-0.5, 1e+30]"},
      {[](FinalLookupSpec& l) { l.lut_min = INFINITY; }, "spec.texture.lut.lut_min = inf must be finite"},
      {[](FinalLookupSpec& l) { l.band_shape = SQUALL_FINAL_IDENTITY; }, "spec.texture.lut.band_shape = 0"},
      {[](FinalLookupSpec& l) { l.field.values.pop_back(); },
       "spec.texture.lut.field.values has 19 values, want nx * ny"},
      {[](FinalLookupSpec& l) { l.field.nx = 1; }, "spec.texture.lut.field.nx = 1 must be in [2, 1048576]"},
      {[](FinalLookupSpec& l) { l.field.hy = 0; },
       "spec.texture.lut.field.spacing.y = 0 must be finite and in [1e-06, 10000000]"},
      {[](FinalLookupSpec& l) { l.field.values[7] = NAN; }, "spec.texture.lut.field.values[7] = nan must be finite"},
      // a bilinear blend of +-3e38 overflows float
      {[](FinalLookupSpec& l) { l.field.values[7] = 3e38f; }, "spec.texture.lut.field.values[7] = 3.00000001e+38 must"},
  };
  for (const Case& k : cases) {
    AdvectSpec spec = static_lut_spec(Method::EulerianMultilayer);
    k.edit(spec.texture.lut);
    expect_error(Code::InvalidArgument, k.needle, [&] { texture_engine().validate(spec, "spec"); });
  }
  AdvectSpec spec = static_lut_spec(Method::EulerianMultilayer);
  spec.texture.lut.field = {};  // no field: s = 0
  texture_engine().validate(spec, "spec");
  spec.texture.final_function = SQUALL_FINAL_RIDGED;  // the lut is ignored by other final functions
  spec.texture.lut.table.clear();
  texture_engine().validate(spec, "spec");
}

// static_lut_spec with a 4 x 4 texture and output, for checks against a small --max-grid-cells.
AdvectSpec small_lut_spec() {
  AdvectSpec spec = static_lut_spec(Method::EulerianMultilayer);
  spec.texture.width = spec.texture.height = 4;
  spec.texture.pixels.resize(16);
  spec.output.width = spec.output.height = 4;
  return spec;
}

TEST(TexturesFinalLut, ScalarFieldPastTheCellLimitIsResourceExhausted) {
  Limits limits;
  limits.max_grid_cells = 19;  // the 5 x 4 field has 20 cells; the output is made smaller
  LimitGate gate(limits);
  TextureEngine engine(runtime(), gate);
  AdvectSpec spec = small_lut_spec();
  expect_error(Code::ResourceExhausted, "spec.texture.lut.field", [&] { engine.validate(spec, "spec"); });
}

// --max-grid-cells bounds a velocity grid's nodes, nx * ny, whatever its number of frames (the frames are
// bounded by the request's size): 5 x 4 nodes in 2 frames pass a limit of 20, 6 x 4 nodes do not.
TEST(TexturesFinalLut, AVelocityGridsCellLimitCountsItsNodesNotItsFrames) {
  Limits limits;
  limits.max_grid_cells = 20;
  LimitGate gate(limits);
  TextureEngine engine(runtime(), gate);
  AdvectSpec spec = small_lut_spec();
  spec.eulerian.grid_nx = spec.eulerian.grid_ny = 4;
  VelocitySpec& v = spec.velocity;
  v.kind = SQUALL_VELOCITY_GRID;
  v.nx = 5, v.ny = 4, v.hx = v.hy = 1;
  v.frames = {VelocityFrame{0, std::vector<float>(20, 0.1f), std::vector<float>(20, 0.0f)},
              VelocityFrame{1, std::vector<float>(20, 0.2f), std::vector<float>(20, 0.0f)}};
  EXPECT_NO_THROW(engine.validate(spec, "spec"));
  v.nx = 6;
  for (VelocityFrame& f : v.frames) f.u.resize(24, 0.1f), f.v.resize(24, 0.0f);
  expect_error(Code::ResourceExhausted, "spec.velocity.grid", [&] { engine.validate(spec, "spec"); });
}

}  // namespace
}  // namespace squall::test
