// Flag values shared by the `squall texture` commands: comma-separated numbers, image files, river files.
// Each throws UsageError naming the flag and the value.
#pragma once

#include <string>
#include <vector>

#include "squall/v1/textures.pb.h"

namespace squall::cli::texture {

// A comma-separated list of finite numbers, of one of the allowed lengths.
std::vector<double> numbers(const std::string& flag, const std::string& text, std::vector<size_t> lengths);
// An image file as a request's image: FILE.exr (its R, G, B, A channels first, at most 8, as float32
// Fields, scanline j as texture row j) or FILE.png (its bytes, decoded by squalld).
void image_flag(const std::string& flag, const std::string& path, squall::v1::ImageTexture* image);
// A river described in a JSON file: squall.v1.RiverVelocity in protobuf's JSON mapping, e.g.
//   {"channels": [{"leftBank": {"points": [{"x": 0, "y": 1}, {"x": 4, "y": 1}]},
//                  "rightBank": {"points": [{"x": 0, "y": 0}, {"x": 4, "y": 0}]}, "flowRate": 1}]}
squall::v1::RiverVelocity river_file(const std::string& flag, const std::string& path);

}  // namespace squall::cli::texture
