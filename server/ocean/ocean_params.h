// The parameters and results of the spectral ocean (J. Tessendorf, "Gilligan: A Prototype Framework for
// Simulating and Rendering Maritime Environments" (2017), sec. 2, and its App. A, J. Tessendorf, "Simulating
// Ocean Water" (SIGGRAPH course notes), sec. 4.3-4.6; bare equation numbers below are Gilligan's, "App A eq"
// ones those of the course notes). Plain C++ (no OpenCL): shared by the engine (ocean_engine.h), the FFTW
// reference (cpu_reference.h) and the RPC layer.
//
// Conventions, SI units throughout:
// - z is up. A tile covers [0, lx) x [0, ly) and repeats periodically. Sample (i, j) of an nx x ny grid sits
//   at x = i lx / nx, y = j ly / ny; fields are row-major, x fastest: value (i, j) at index i + nx * j.
// - Wave vector of mode (n, m): k = (2 pi n / lx, 2 pi m / ly), -nx/2 < n < nx/2 (the Nyquist row and
//   column are zero so that spectral derivatives stay real). Angles are radians counter-clockwise from +x.
// - A wind direction theta0 is the direction the wind blows TOWARDS, and the waves of every spreading
//   model travel towards it (downwind).
// - h(x, t) = sum_k h~(k, t) exp(i k.x) with h~(k, t) = [h0(k) e^{-i w t} + conj(h0(-k)) e^{+i w t}]
//   e^{-i k.U_D t} (eq 1, App A eq 43; the sign of w t is chosen so that h0(k) travels along +k, and the
//   drift factor translates the whole field by +U_D t). h0(k) = (xi_r + i xi_i) sqrt(P(k) dkx dky / 2) (App A
//   eq 42 with the amplitude scaled by sqrt(dkx dky) and an unnormalized inverse DFT, in place of eq 2's
//   factor dkx dky on the output), so E[h^2] = sum_k (P(k) + P(-k)) dkx dky ~ m0.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/float_view.h"

namespace squall::ocean {

// Frequency spectrum S(omega) of a layer (eqs 4-26), or Phillips' P(k) (App A eqs 40-41).
enum class SpectrumModel : int {
  Phillips = 0,          // P(k) = A exp(-1/(kL)^2) / k^4 |k^.w^|^p exp(-k^2 l^2), L = U^2/g; no S, no D
  PiersonMoskowitz = 1,  // eq 4 with exp[-5/4 (w_p/w)^4] (printed (w/w_p)^4), alpha = 0.0081, w_p = 0.879 g/U
  Jonswap = 2,           // eqs 5-12 (alpha, w_p from fetch; sigma_a for w <= w_p, sigma_b for w > w_p)
  ModifiedJonswap = 3,   // eqs 13-19, gamma and beta from U / c_p = 2 pi nu (Donelan et al. 1985)
  Tma = 4,               // eqs 20-23: JONSWAP times the depth factor r(w*), f solved by Newton; uses depth
  Multipeak = 5,         // eqs 24-26: a sum of partial spectra (partials), each scaled to its own Hs
};
constexpr int kSpectrumModelCount = 6;

// Directional spreading D(theta; omega, k), each normalized so that its integral over theta in
// [-pi, pi) is 1 (misprints fixed: as printed, eq 27 integrates to 4/pi, eq 29 to 24 at s = 1, and eq 45
// peaks perpendicular to the wind).
enum class SpreadingModel : int {
  Isotropic = 0,    // 1 / (2 pi)
  PiersonCos2 = 1,  // (2/pi) cos^2(theta - theta0) on |theta - theta0| < pi/2, else 0 (eq 27 fixed)
  Krylov = 2,  // Gamma(s/2+1) / (sqrt(pi) Gamma((s+1)/2)) cos^s on the half plane, s = 1.8 wbar / w (eqs 29-31 fixed)
  Mitsuyasu = 3,   // eqs 33-37: cos^{2s}((theta - theta0)/2), s from w U / g; needs wind_speed > 0
  Jonswap = 4,     // eqs 38-41 (central values of s_p and mu); needs wind_speed > 0
  VonMises = 5,    // eqs 43-44 with s of eq 34; needs wind_speed > 0
  Hyperbolic = 6,  // (beta/2) sech^2(beta (theta - theta0)) / tanh(beta pi) (eq 45 fixed, Donelan), beta of eq 46
};
constexpr int kSpreadingModelCount = 7;

// Dispersion relation of Table 1 (kernels/common/dispersion.h).
enum class DispersionKind : int {
  Deep = 0,       // w^2 = g k
  Shallow = 1,    // w^2 = g k tanh(k h)
  Capillary = 2,  // w^2 = g k (1 + (k l)^2)
  Combined = 3,   // w^2 = g k tanh(k h) (1 + (k l)^2)
};
constexpr int kDispersionKindCount = 4;

// One partial spectrum of the Multipeak model (eqs 24-26):
//   S(w) = scale * { A exp[-B (w/w_p - 1)^2] + C (w/w_p)^-n exp[-7.987 (w/w_p)^-m] },
// where scale is chosen so that the partial's m0 = integral S dw equals (Hs / 4)^2.
struct PartialSpectrum {
  double peak_frequency = 0.6;         // w_p, rad/s, > 0
  double significant_wave_height = 1;  // Hs of this partial, m, > 0
  double a = 1.835, b = 22.2222, c = 4.211, n = 5,
         m = 8;  // dimensionless shape (eq 26's values); a, b, c >= 0, n, m > 0
};
constexpr int kMaxPartialSpectra = 4;

// One layer: a periodic patch with its own extent, grid, spectrum and random seed.
struct LayerSpec {
  // Patch and grid.
  double lx = 256, ly = 256;   // m, finite, > 0
  int64_t nx = 128, ny = 128;  // cells, even, >= 2; nx * ny within the daemon's --max-grid-cells

  // Frequency spectrum.
  SpectrumModel spectrum = SpectrumModel::PiersonMoskowitz;
  double wind_speed = 10;            // U, m/s at 10 m, finite, > 0 (every model but Multipeak; Multipeak: >= 0)
  double fetch = 100e3;              // X, m, > 0 (Jonswap, ModifiedJonswap, Tma)
  double gamma = 3.3;                // peak enhancement, >= 1 (Jonswap, Tma)
  double sigma_a = 0.07;             // JONSWAP width for w <= w_p, > 0
  double sigma_b = 0.09;             // JONSWAP width for w > w_p, > 0
  double phillips_amplitude = 1e-3;  // Phillips A, m^2 (P in m^4), >= 0
  double phillips_cutoff = 0;        // Phillips small-wave cutoff l, m, >= 0
  double phillips_exponent = 2;      // Phillips directional exponent p of |k^.w^|^p, >= 0 (App A eq 40: 2, Fig 11: 6)
  std::vector<PartialSpectrum> partials;  // Multipeak: 1 .. kMaxPartialSpectra entries

  // Directional spreading (ignored by Phillips, which has its own |k^.w^|^p).
  SpreadingModel spreading = SpreadingModel::Mitsuyasu;
  double wind_direction = 0;  // theta0, rad, finite; the waves travel towards theta0

  // Dispersion.
  DispersionKind dispersion = DispersionKind::Deep;
  double depth = 100;                // h, m, > 0 (Shallow, Combined dispersion and the Tma spectrum)
  double capillary_length = 2.7e-3;  // l, m, >= 0 (Capillary, Combined)
  double gravity = 9.81;             // g, m/s^2, > 0

  uint64_t seed = 1;                // random amplitudes: keyed by (seed, n, m, layer index)
  double drift_x = 0, drift_y = 0;  // U_D, m/s, finite: the field translates by +U_D t (eq 1)
  double k_min = 0, k_max = 0;      // rad/m: modes with |k| < k_min or (k_max > 0 and |k| > k_max) are 0
};

// Bit flags of the fields a tile request asks for.
enum Output : unsigned {
  Height = 1u << 0,        // h, m
  Displacement = 1u << 1,  // lambda * D (x, y), m; the surface point of grid point x is x + lambda D
  Slopes = 1u << 2,        // dh/dx, dh/dy (spectral derivatives, eq 37)
  Normals = 1u << 3,       // unit normal (x, y, z) of the displaced surface (eq 94; eq 90 when lambda = 0)
  Jacobian = 1u << 4,      // J, J-, J+ of the horizontal map x -> x + lambda D (App A eqs 45-47)
  Whitecaps = 1u << 5,     // whitecap map in [0, 1] (section 5.3.3)
};
constexpr unsigned kAllOutputs = Height | Displacement | Slopes | Normals | Jacobian | Whitecaps;

// Bit flags of single fields (planes), for reading back fewer than the Output groups hold: bit i is the
// i-th field of TileFields (plane::Index).
constexpr int kPlaneCount = 12;
constexpr unsigned kAllPlanes = (1u << kPlaneCount) - 1;
namespace plane {
enum Index : int {
  Height,
  DisplacementX,
  DisplacementY,
  SlopeX,
  SlopeY,
  NormalX,
  NormalY,
  NormalZ,
  Jacobian,
  JacobianMinus,
  JacobianPlus,
  Whitecaps
};
constexpr unsigned bit(Index i) { return 1u << i; }
}  // namespace plane

// A tile: the sum of its layers, sampled on the output grid.
struct TileSpec {
  std::vector<LayerSpec> layers;  // >= 1
  // Eqs 56-57: scale each layer's amplitude at k by B(k)^-1/2, B(k) = the COUNT of layers whose band
  // contains k (sec. 2.6 calls it "the square of the number of realizations", but with Pi = 0 or 1 eq 56 is
  // the count). A layer's band is the set of wave vectors its grid represents: |kx| < (nx - 1) pi / lx,
  // |ky| < (ny - 1) pi / ly, outside the cell |kx| < pi/lx and |ky| < pi/ly of the mean.
  bool b_correction = false;
  // lambda, dimensionless, finite. Displacement convention: D(x) = sum_k i (k/|k|) h~(k) e^{ik.x}, which is
  // eq 47 with the OPPOSITE sign, so that lambda > 0 sharpens crests (J is smallest at the crests and
  // folds, J < 0, appear there when lambda is large). lambda = 0: no horizontal motion.
  double choppiness = 1.0;
  // Output grid; nx = ny = 0 (or lx = ly = 0): the first layer's grid. Each layer is evaluated on its own
  // grid by FFT and sampled onto the output grid periodically (exactly at coinciding grid points,
  // bilinearly between them).
  int64_t nx = 0, ny = 0;
  double lx = 0, ly = 0;
  double whitecap_threshold = 0.3;  // J- below this sets the whitecap map to 1; finite
  double whitecap_decay = 4;        // T, s, > 0: elsewhere the map decays by exp(-dt / T) (an e-folding time)
  // R, m, >= 0: pixel scale of eq 96 (sigma_U^2 = slope variance of the waves with |k| > pi / R).
  // 0: the output grid's cell size max(lx/nx, ly/ny).
  double pixel_scale = 0;
  double slope_k_max = 1000;  // rad/m, > 0: upper limit of the eq-96 integral (the slope variance of
                              // the wind spectra diverges logarithmically without one)
};

// The fields of one tile: float32, row-major x fastest on the output grid; empty when not requested.
// The engine's fields are views of the memory it read them into (a pinned host block, or on a CPU device
// the buffer it computed them in), which goes back to the runtime's pool with the last view of it: they
// must not outlive the engine's runtime.
struct TileFields {
  int64_t nx = 0, ny = 0;
  double dx = 0, dy = 0;  // m, cell size
  double t = 0;           // s
  FloatView height;
  FloatView displacement_x, displacement_y;
  FloatView slope_x, slope_y;
  FloatView normal_x, normal_y, normal_z;
  FloatView jacobian, jacobian_minus, jacobian_plus;  // J, J- <= J+
  FloatView whitecaps;
  // Eq 96 (sign fixed): sigma_U^2 = integral over pi/R < |k| < slope_k_max of k^2 (P(k) + P(-k)) d^2k,
  // summed over layers (with b_correction: the mean of the layers' spectra, which are then taken as
  // realizations of one physical spectrum). Dimensionless (slope^2).
  double unresolved_slope_variance = 0;
};

// The field of plane i (kAllPlanes bit i): tile.*kTilePlanes[i].
inline constexpr FloatView TileFields::*kTilePlanes[kPlaneCount] = {
    &TileFields::height,   &TileFields::displacement_x, &TileFields::displacement_y, &TileFields::slope_x,
    &TileFields::slope_y,  &TileFields::normal_x,       &TileFields::normal_y,       &TileFields::normal_z,
    &TileFields::jacobian, &TileFields::jacobian_minus, &TileFields::jacobian_plus,  &TileFields::whitecaps};

// The planes (kAllPlanes bits) of the Output groups `outputs`.
constexpr unsigned planes_of(unsigned outputs) {
  namespace p = plane;
  const unsigned groups[][2] = {{Height, bit(p::Height)},
                                {Displacement, bit(p::DisplacementX) | bit(p::DisplacementY)},
                                {Slopes, bit(p::SlopeX) | bit(p::SlopeY)},
                                {Normals, bit(p::NormalX) | bit(p::NormalY) | bit(p::NormalZ)},
                                {Jacobian, bit(p::Jacobian) | bit(p::JacobianMinus) | bit(p::JacobianPlus)},
                                {Whitecaps, bit(p::Whitecaps)}};
  unsigned planes = 0;
  for (const auto& [group, bits] : groups)
    if (outputs & group) planes |= bits;
  return planes;
}

// Whitecap map carried by the caller across the frames of one stream (same spec, increasing t).
// The first frame starts from 0; each later frame sets 1 where J- < threshold and multiplies the rest by
// exp(-(t - t_previous) / T). A frame whose t precedes the previous one is InvalidArgument.
class WhitecapState {
 public:
  bool empty() const { return map_.empty(); }
  void reset() { map_.clear(); }
  const std::vector<float>& map() const { return map_; }
  double last_t() const { return last_t_; }

  // Used by the engines: the map and time after a frame.
  std::vector<float>& mutable_map() { return map_; }
  void set(int64_t nx, int64_t ny, double t) {
    nx_ = nx;
    ny_ = ny;
    last_t_ = t;
  }
  bool matches(int64_t nx, int64_t ny) const { return !map_.empty() && nx == nx_ && ny == ny_; }

 private:
  std::vector<float> map_;
  int64_t nx_ = 0, ny_ = 0;
  double last_t_ = 0;
};

struct Vec2 {
  double x = 0, y = 0;
};

// The surface at one world point, summed over all layers.
struct SurfaceSample {
  Vec2 source;                                    // m: the surface point before its displacement
  double height = 0;                              // m
  double displacement_x = 0, displacement_y = 0;  // m, lambda * D at the (source) point
  double normal_x = 0, normal_y = 0, normal_z = 1;
};

}  // namespace squall::ocean
