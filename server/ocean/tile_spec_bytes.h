// An ocean TileSpec (ocean_params.h) as bytes and back: every member of the spec, its layers and their
// partial spectra, for what keeps a spec beyond a request (an eWave session's checkpoint holds its
// config's ambient_ocean this way). The byte codec's layout (common/byte_codec.h), independent of the host:
// little-endian, f64 an IEEE 754 binary64 (its bits as a u64), i32 / i64 two's complement, u8 / u32 / u64
// unsigned; no padding.
//
// Format version 1:
//   offset  size  field
//   0       8     magic "SQOCNSPC"
//   8       4     u32 format version (1)
//   12      1     u8 b_correction (0 or 1)
//   13      8     f64 choppiness
//   21      8     i64 nx
//   29      8     i64 ny
//   37      8     f64 lx
//   45      8     f64 ly
//   53      8     f64 whitecap_threshold
//   61      8     f64 whitecap_decay
//   69      8     f64 pixel_scale
//   77      8     f64 slope_k_max
//   85      4     u32 layer count L, then the L layers back to back, and nothing after the last.
// A layer (its partials make its length vary; sizes in bytes, in this order):
//   8 f64 lx, 8 f64 ly, 8 i64 nx, 8 i64 ny, 4 i32 spectrum (SpectrumModel), 8 f64 wind_speed, 8 f64 fetch,
//   8 f64 gamma, 8 f64 sigma_a, 8 f64 sigma_b, 8 f64 phillips_amplitude, 8 f64 phillips_cutoff,
//   8 f64 phillips_exponent, 4 u32 partial count P, P partials of 7 f64 each (peak_frequency,
//   significant_wave_height, a, b, c, n, m), 4 i32 spreading (SpreadingModel), 8 f64 wind_direction,
//   4 i32 dispersion (DispersionKind), 8 f64 depth, 8 f64 capillary_length, 8 f64 gravity, 8 u64 seed,
//   8 f64 drift_x, 8 f64 drift_y, 8 f64 k_min, 8 f64 k_max.
// The layers start at offset 89; a layer without partials is 184 bytes, and each partial adds 56.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "ocean/ocean_params.h"

namespace squall {
class LimitGate;
}

namespace squall::ocean {

inline constexpr uint32_t kTileSpecBytesVersion = 1;

std::string encode_tile_spec(const TileSpec& spec);

// The spec of `bytes`, validated like every tile request (validate_tile, with `gate`'s grid limit).
// Throws Error(InvalidArgument) naming `path`: "<path> is not an ocean tile spec: truncated at byte 89 of
// 100 (reading <path>.layers[0].lx)", a wrong magic or version, bytes after the last layer, a flag that is
// neither 0 nor 1; then validate_tile's own messages ("<path>.layers[0].wind_speed = nan must be ...").
TileSpec decode_tile_spec(std::string_view bytes, const LimitGate& gate, const std::string& path);

}  // namespace squall::ocean
