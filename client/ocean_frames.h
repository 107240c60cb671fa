// Client side of squall.v1.Ocean: reassembling StreamTiles' chunked frames, and turning fields into
// float values and images.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "client/image_io.h"
#include "squall/v1/ocean.grpc.pb.h"

namespace squall::client::ocean {

// Collects the chunks of StreamTiles into whole frames. Chunks must arrive in order (gRPC keeps the
// order of one stream); a chunk out of sequence throws std::runtime_error naming what was expected.
class FrameAssembler {
 public:
  // Returns the frame once its last chunk arrived, as GetTile would have answered it.
  // Field bytes are moved out of `chunk` (a whole field without a copy).
  std::optional<squall::v1::GetTileResponse> add(squall::v1::TileChunk& chunk);

 private:
  squall::v1::GetTileResponse frame_;
  std::vector<std::string> names_;  // fields of the current frame, in order of first piece
  uint32_t next_chunk_ = 0;
  uint32_t frame_index_ = 0;
  bool started_ = false;
};

// The values of a float32 or float16 field as floats (common/field_codec.h: throws squall::Error naming
// the field on a dtype or size mismatch).
std::vector<float> values(const squall::v1::Field& field);

// An EXR image of a tile: one channel per field, attributes from `request` (every field of the message,
// recursively, as "squall.<path>") plus the fields' units, spacing and origin.
Image tile_image(const squall::v1::GetTileResponse& tile, const google::protobuf::Message& request);

}  // namespace squall::client::ocean
