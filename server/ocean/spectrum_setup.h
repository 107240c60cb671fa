// Host-side set-up of the ocean engine: request validation, the derived spectrum parameters of a layer
// (w_p, alpha, mean frequency, multipeak scales), the device parameter block, the B(k) bands and the
// unresolved slope variance of eq 96.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "common/limits.h"
#include "common/validate.h"
#include "ocean/ocean_params.h"

#include "ocean/params.h"
#include "ocean/spectra.h"

namespace squall::ocean {

inline constexpr int kMaxLayers = 8;
// Ranges of the fields whose request names differ from the engine's (extent_x is lx, peak_enhancement is
// gamma, sigma_below_peak / sigma_above_peak are sigma_a / sigma_b): the request translation checks them
// under their request names with these same ranges.
inline const validate::Interval kExtentRange = validate::closed(1e-3, 1e6);        // m
inline const validate::Interval kPeakEnhancementRange = validate::closed(1, 100);  // JONSWAP gamma
inline const validate::Interval kPeakWidthRange = validate::open_closed(0, 10);    // JONSWAP sigma

// The one validation of a tile: every range is checked here. Throws Error(InvalidArgument) naming the
// field under `path` ("tile" -> "tile.layers[1].wind_speed"), or ResourceExhausted from the gate.
void validate_tile(const TileSpec& spec, const LimitGate& gate, const std::string& path = "");

// The formula parameters of a layer (spectra.h) in double precision.
SpectrumParams derive_spectrum(const LayerSpec& layer);

// The layer's dispersion relation, as the kernels take it (common/dispersion.h).
Dispersion dispersion_of(const LayerSpec& layer);

// The device block of layer `index` (params.h).
OceanLayer device_layer(const LayerSpec& layer, int index);

// f(k) = omega(k) / 2 pi of `count` modes of a layer from mode (i, j) at i + nx j = first on (mode numbers as
// in ocean.cl), turns per second, in double precision and stored as two floats f = hi + lo. The device's
// phases f t then follow the double-precision dispersion at any t and on every device alike
// (kernels/common/sincos.h).
void mode_frequencies(const LayerSpec& layer, size_t first, size_t count, float* hi, float* lo);

// (kx_min, ky_min, kx_max, ky_max) of each layer's band (eq 56 and TileSpec::b_correction).
std::vector<std::array<float, 4>> layer_bands(const TileSpec& spec);

// Eq 96 with the sign fixed (TileFields::unresolved_slope_variance).
double unresolved_slope_variance(const TileSpec& spec);

// The output grid (TileSpec nx/ny/lx/ly, or the first layer's).
struct OutputGrid {
  int64_t nx, ny;
  double lx, ly;
};
OutputGrid output_grid(const TileSpec& spec);

// The spectral channels a tile transforms (kernels/ocean/ocean.cl): the leading `pairs` of the displaced
// layout (h, Dx), (Dy, eps_x), (eps_y, Dxx), (Dyy, Dxy), or, where no displacement is asked for but slopes or
// derivatives are, of the undisplaced layout (h, eps_x), (eps_y, Dxx), (Dyy, Dxy): one pair fewer.
struct ChannelLayout {
  int pairs;       // 1 to 4 displaced, 2 or 3 undisplaced
  bool displaced;  // the layout
};
ChannelLayout channel_layout(unsigned outputs);

}  // namespace squall::ocean
