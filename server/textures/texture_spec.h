// What an advection request asks for, validated by TextureEngine::validate(spec, path): the
// domain, the velocity field, the reference texture and its final function, the output, the method and
// its parameters. Units: domain units (du) for lengths, seconds, texture periods for texture coordinates.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "textures/fields.h"

namespace squall::textures {

enum class Method {
  LagrangianGrids,     // Yu, Neyret, Bruneton, Holzschuch 2011 (particles carrying deformable grids)
  EulerianMultilayer,  // F. Neyret, "Advected Textures" (SCA 2003): N layers of regenerated coordinates
  TwoPhaseFlowMap,     // the game engines' flow map: one layer, two phases half a latency apart
  Naive,               // texture coordinates advected, never regenerated (the negative control)
};
constexpr int kMethods = 4;
constexpr int kMaxTextureFrames = 100000;  // frames of one AdvectTexture stream
constexpr double kMaxTextureDt = 1e4;      // s between frames
constexpr int kMaxTextureSubsteps = 64;    // integration steps per frame
constexpr double kMaxTextureTime = 1e9;    // s: t0 within +-1e9 (a SimTime's range)
constexpr double kMaxFrameTime = 1e10;     // s: a velocity grid's frame times (a followed current's: past t0's)
constexpr double kMaxSpin = 1e6;           // rad/s: flow noise's band-0 turn rate within +-1e6
constexpr int kMaxGridSide = 1 << 20;      // nodes along a side of a velocity or scalar grid
// Analytic velocity parameters (du, du/s, s) within +-kMaxVelocityParam (the device works in float32);
// those a field divides by at least kMinVelocityDivisor.
constexpr double kMaxVelocityParam = 1e9, kMinVelocityDivisor = 1e-6;
// Output region and velocity grid coordinates within +-kMaxCoordinate (du: float32 on the device), and an
// output pixel at least 2^-19 of the region's largest coordinate (16 or more of float32's steps there).
constexpr double kMaxCoordinate = 1e7, kMinPixelPerCoordinate = 0x1p-19;
// Texture values (image pixels, LUT entries and inputs) within +-kMaxTextureValue, and the final function's
// scale within +-kMaxFinalScale: a bilinear blend or a LUT's slope of such values stays finite in float32
// (3e38 entries made infinities and NaN).
constexpr double kMaxTextureValue = 1e30, kMaxFinalScale = 1e6;
// Coordinates a stream's state can reach (texture coordinates, the Lagrangian grids' vertices and
// deformations): the region's kMaxCoordinate and kMaxVelocityParam du/s over the longest stream
// (kMaxTextureFrames x kMaxTextureDt) make 1e18. A checkpoint holding a value past +-kMaxStateValue is
// none of this server's (3e38 made planes of NaN: a noise band scales coordinates by up to 64 x 2^7).
constexpr double kMaxStateValue = 1e20;
// Layer latencies, s: a regeneration far faster than any frame (1e-310 s) divided by zero.
constexpr double kMinLatency = 1e-3;

// A velocity grid outside its nodes or its fluid: held at the edge nodes, zero, push-pull filled (then held),
// or periodic (node nx is node 0 again: an ocean tile's current).
enum class Extrapolation { Clamp, Zero, PushPull, Wrap };

struct VelocityFrame {
  double time = 0;          // s
  std::vector<float> u, v;  // du/s, nx * ny each, x fastest
};

struct VelocitySpec {
  int kind = SQUALL_VELOCITY_UNIFORM;                   // SQUALL_VELOCITY_* (fields.h)
  std::array<double, SQUALL_VELOCITY_PARAMS> params{};  // analytic parameters, as fields.h lists them
  // SQUALL_VELOCITY_GRID only:
  int nx = 0, ny = 0;                 // nodes, >= 2 each
  double origin_x = 0, origin_y = 0;  // du, position of node (0, 0)
  double hx = 0, hy = 0;              // du, > 0
  std::vector<VelocityFrame> frames;  // increasing times; linear in time between them, held outside
  Extrapolation extrapolation = Extrapolation::Clamp;
  std::vector<uint8_t> mask;  // nx * ny, nonzero = fluid; empty = all fluid
};

// A scalar field s(x) on nodes (dimensionless): bilinear in space, clamped to its edge nodes.
struct ScalarGridSpec {
  int nx = 0, ny = 0;                 // nodes, >= 2 each; 0 and no values: no field (s = 0)
  double origin_x = 0, origin_y = 0;  // du, position of node (0, 0)
  double hx = 0, hy = 0;              // du, > 0
  std::vector<float> values;          // nx * ny, x fastest
};

// The final function SQUALL_FINAL_LUT (LTA11 sec. 3.2, fire example): T = LUT(s(x) + final_scale
// sum_j 2^-j g(a_j)), the table linear between its entries and clamped at its ends.
struct FinalLookupSpec {
  ScalarGridSpec field;
  int64_t channels = 1;                  // C, output channels per entry (final planes), 1..4
  std::vector<float> table;              // N entries of C values, entry after entry; N in 2..4096
  double lut_min = 0, lut_max = 1;       // input range: entry k at lut_min + k (lut_max - lut_min) / (N - 1)
  int band_shape = SQUALL_FINAL_RIDGED;  // g: SQUALL_FINAL_SUM_BANDS, _TURBULENCE or _RIDGED
};

struct TextureSpec {
  int kind = SQUALL_TEXTURE_NOISE;  // SQUALL_TEXTURE_*
  // Image: `channels` planes of width x height, x fastest, one period of a tileable texture.
  int width = 0, height = 0, channels = 1;
  std::vector<float> pixels;
  // Noise: `bands` channels b_j(2^j u).
  int64_t bands = 4;
  double base_cells = 4;      // lattice cells per period in band 0, 1..64
  bool time_varying = false;  // flow noise: its gradients turn (spin); false: a still texture
  double spin = 0;            // flow noise: rad/s of band 0; 0 for a still texture
  uint32_t seed = 1;
  double scale = 4;                            // S, texture periods per du
  int final_function = SQUALL_FINAL_IDENTITY;  // SQUALL_FINAL_*
  double final_scale = 1;
  FinalLookupSpec lut;  // SQUALL_FINAL_LUT only
};

// The output frames: width x height pixels over the region [x0, x1] x [y0, y1] (du); pixel (px, py)
// samples the region at its centre.
struct OutputSpec {
  int width = 128, height = 128;
  double x0 = 0, y0 = 0, x1 = 1, y1 = 1;
};

enum class Blend {
  VariancePreserving,  // LTA11 eq. 4: sum w (R - Rhat) / sqrt(sum w^2) + Rhat
  Normalized,          // LTA11 eq. 3: sum w R / sum w
};

enum class PatchOrigin {
  Random,  // each grid maps a random patch of the reference texture (LTA11 sec. 3.3.1)
  Window,  // each grid starts registered to the domain: u = S x at birth
};

struct LagrangianParams {
  double d = 0.1;          // Poisson radius (du); blending kernel radius
  double alpha = 0.25;     // particles closer than (1 - alpha) d are culled
  double beta = 0.6;       // grids are (2 + beta) d wide
  int64_t grid_res = 8;    // G x G vertices per grid, 3..16
  double delta_max = 2.0;  // eq. 2: distortion at which the quality reaches 0
  double fade_tau = 0.5;   // s, fade-in and fade-out durations (eq. 6)
  Blend blend = Blend::VariancePreserving;
  PatchOrigin patch_origin = PatchOrigin::Random;
};

enum class PhaseWeight {
  Cosine,    // ADV03: (1 - cos(2 pi age / latency)) / phases
  Triangle,  // game engines' flow maps: 1 - |2 age / latency - 1|
};

enum class DeformationSum {
  Weighted,  // d^i = phases * sum_j alpha_j d_j: continuous in time
  Paper,     // d^i = sum_j d_j (ADV03 sec. 2.1)
};

enum class EulerianBlend {
  Octave,                    // blend the channels (noise octaves), then F (ADV03 sec. 3)
  Final,                     // classical: F per parameterization, then blend (ghosting)
  OctaveVariancePreserving,  // the channels blended with eq. 4 of LTA11, then F
};

// The vorticity cascade of F. Neyret, "Advected Textures" (SCA 2003), sec. 4: every advection node carries,
// per noise band k, a vorticity w_k (rad/s) and a phase theta_k (rad), advected with the fluid; each step
// w_0 = c_w |omega| (omega = dv_y/dx - dv_x/dy), w_k := beta_k w_k + (1 - beta_k) w_(k-1) for k >= 1 with
// beta_k = 2^(-dt / tau_k) (tau_k: band k's half-life, time constant tau_k / ln 2) and
// tau_k = tau tau_ratio^(k-1), then theta_k += w_k dt; band k's gradients turn by theta_k on top of the
// flow-noise spin. All start at 0.
struct VorticityCascade {
  double c_w = 0;                         // rad per unit of vorticity (dimensionless), >= 0; 0: off
  double tau = 0.5;                       // s, > 0: tau_1
  double tau_ratio = 0.6299605249474366;  // > 0; 2^(-2/3): Kolmogorov's eddy turnover time ~ scale^(2/3)
};

struct EulerianParams {
  std::vector<double> latencies = {0.6, 2.3, 4.0};  // s, one layer each, increasing
  int64_t phases = 3;                               // regenerated parameterizations per layer, 2 or 3
  PhaseWeight weight = PhaseWeight::Cosine;
  double d_star = 1.0;  // target accumulated deformation (dimensionless, integral of |e| dt)
  DeformationSum deformation = DeformationSum::Weighted;
  EulerianBlend blend = EulerianBlend::Octave;
  int64_t grid_nx = 64, grid_ny = 64;  // advection nodes over the output region
  VorticityCascade cascade;            // EulerianMultilayer with a noise texture only
  // Each regeneration resets a phase to S x + o, o uniform in [0, 1)^2 periods, drawn per (seed, slot,
  // regeneration): the phases decorrelate (ADV03 resets to S x, o = 0: zero velocity is then static).
  bool random_offset = false;
};

struct AdvectSpec {
  Method method = Method::LagrangianGrids;
  VelocitySpec velocity;
  TextureSpec texture;
  OutputSpec output;
  double t0 = 0;         // s, time of frame 0
  double dt = 1.0 / 30;  // s between frames, > 0
  // Counts as the request sent them (validated against their ranges before use, and named as sent).
  int64_t frames = 1;
  int64_t substeps = 1;  // integration steps per frame
  uint64_t seed = 1;
  LagrangianParams lagrangian;
  EulerianParams eulerian;  // method EulerianMultilayer (TwoPhaseFlowMap and Naive set their own)
};

}  // namespace squall::textures
