// Writing grids to image files for people and tools: OpenEXR (lossless, every channel as 32-bit FLOAT,
// every request parameter as a string attribute of the header) and an 8-bit grey PNG preview.
// gRPC-free: the CLI fills an Image from the reply's fields.
//
// Orientation: scanline j of the file is grid row j (world y = origin.y + j * spacing.y), column i is
// grid column i (world x = origin.x + i * spacing.x). No flip, so pixel (i, j) is the Field's value at
// index i + nx * j.
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace squall::client {

struct Channel {
  std::string name;           // EXR channel name, e.g. "height"
  std::vector<float> values;  // nx * ny values, x fastest
};

struct Image {
  int nx = 0;
  int ny = 0;
  std::vector<Channel> channels;
  // Header attributes, written as OpenEXR string attributes (name -> value). Names must not clash with
  // OpenEXR's own (channels, compression, dataWindow, ...); prefix them, e.g. "squall.tile.lambda".
  std::vector<std::pair<std::string, std::string>> attributes;
};

// How a preview maps values to 8-bit grey.
// - Range: linearly from [min, max] of the finite values to [0, 255] (a constant field is mid-grey): for
//   fields of both signs and a bounded range, as heights and displacements are.
// - Radiance: for light, which is >= 0 and of high dynamic range: exposed so that the 99th percentile of
//   the finite values above 0 is white (what is not lit, a background of sky, does not count), clipped
//   above it, and sRGB-encoded (IEC 61966-2-1): a lamp's glow shows around it, not as the one white pixel
//   that Range would give.
// Non-finite values are black in both, and so is an image of no value above 0 in Radiance.
enum class Tone { Range, Radiance };
std::vector<unsigned char> preview_grey(const std::vector<float>& values, Tone tone);

// Writes `exr` and, unless `png` is empty, the preview of its first channel to `png`: both or neither (an
// EXR written before its preview failed is removed). Throws what the failing write threw.
void write_exr_and_preview(const std::string& exr, const Image& image, const std::string& png, Tone tone = Tone::Range);

// Adds "squall.time_seconds": a frame's time, s, with 17 significant digits (read back as the same double).
void add_time_attribute(Image& image, double seconds);

// Writes a scanline EXR with ZIP compression. Throws std::runtime_error naming the path on failure or
// when a channel does not hold nx * ny values.
void write_exr(const std::string& path, const Image& image);

// Writes values (nx * ny, x fastest) as 8-bit grey, mapped by `tone`. Throws on failure.
void write_png_preview(const std::string& path, int nx, int ny, const std::vector<float>& values,
                       Tone tone = Tone::Range);
// The preview written beside an EXR `output`: its ".exr" replaced by ".png", else ".png" appended (an
// output named x.png keeps its EXR, and one in a dotted folder its own folder).
std::string preview_beside(const std::string& output);

}  // namespace squall::client
