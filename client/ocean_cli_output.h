// What `squall ocean` writes: tiles as EXR (one channel per field, the request as attributes) with a
// PNG preview of the first field, stream frames as DIR/frame_NNNNN.exr, samples as CSV.
#pragma once

#include <cstdint>
#include <ostream>
#include <string>

#include "client/ocean_cli_request.h"
#include "squall/v1/ocean.pb.h"

namespace squall::cli::ocean {

// The preview of `tile`: --preview FILE, "" for --preview none, else -o with the extension .png.
std::string preview_path(const Request& r);

// The EXR of stream frame `index` under `dir`: "DIR/frame_00007.exr".
std::string frame_path(const std::string& dir, uint32_t index);

// Writes `tile` to `exr` (and the first field's greyscale preview to `png` unless it is empty).
void write_tile(const squall::v1::GetTileResponse& tile, const google::protobuf::Message& request,
                const std::string& exr, const std::string& png);

// The CSV of `sample`: a header line, then one line per point of r.points.
void write_samples(std::ostream& out, const Request& r, const squall::v1::SampleSurfaceResponse& s);

}  // namespace squall::cli::ocean
