// Splitting one StreamTiles frame into messages under --max-message-bytes: whole fields where they fit,
// bands of rows where a field does not. Part of squall_rpc.
#pragma once

#include <cstdint>
#include <vector>

#include "squall/v1/ocean.pb.h"

namespace squall::ocean::rpc {

// Rows [row, row + rows) of field `field` (an index into the frame's fields).
struct PieceRef {
  int field = 0;
  uint32_t row = 0;
  uint32_t rows = 0;
};
using ChunkPlan = std::vector<std::vector<PieceRef>>;  // chunks, each a list of pieces

// Bytes a chunk may spend on field data when messages are limited to max_message_bytes: the limit less a
// reserve for the chunk's and pieces' headers.
uint64_t chunk_payload_budget(uint64_t max_message_bytes);

// Packs `fields` (all of size ny rows of row_bytes each) greedily into chunks of at most `budget` data
// bytes, in field order. Throws squall::Error(ResourceExhausted) when a single row exceeds the budget.
ChunkPlan plan_chunks(const std::vector<uint64_t>& row_bytes, const std::vector<uint32_t>& ny, uint64_t budget);

// The chunk `index` of a frame whose fields (complete, as GetTile returns them) are `frame`. A piece that
// is a whole field takes its bytes from `frame` without copying (frame's field data is left empty), so
// call it once per chunk index.
void fill_chunk(squall::v1::GetTileResponse& frame, const ChunkPlan& plan, uint32_t index, uint32_t frame_index,
                squall::v1::TileChunk* chunk);

}  // namespace squall::ocean::rpc
