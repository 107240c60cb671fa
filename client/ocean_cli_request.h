// `squall ocean` flags -> what the verbs send: the layer flags (applied to the current layer; --add-layer
// starts a copy), the tile flags and the run flags (time, frames, output, points). Parsing throws
// UsageError naming the flag and the value.
#pragma once

#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "squall/v1/ocean.pb.h"

namespace squall::cli::ocean {

// The flags of `squall ocean help`.
extern const char* const kHelp;

// Everything the three verbs take from the command line.
struct Request {
  squall::v1::TileSpec tile;
  std::vector<squall::v1::TileOutput> outputs;
  squall::v1::DType dtype = squall::v1::DTYPE_FLOAT32;
  double time = 0, t0 = 0, dt = 0;
  uint64_t frames = 0;
  bool have_dt = false, have_frames = false, invert = false;
  std::string out, preview;
  std::vector<std::pair<double, double>> points;
  std::vector<std::string> run_flags;  // the flags of kVerbFlags given, as typed
};

// The flags beside the layer and tile flags that each verb reads ("tile", "stream", "sample"); a verb
// refuses the others.
extern const std::map<std::string, std::set<std::string>> kVerbFlags;

// The request of `squall ocean VERB FLAGS...` (args[0] is the verb; the flags follow). Defaults: one
// JONSWAP layer of 1000 m on a 256 x 256 grid, choppiness 1, height, displacement and normals.
Request parse(const std::vector<std::string>& args);

}  // namespace squall::cli::ocean
