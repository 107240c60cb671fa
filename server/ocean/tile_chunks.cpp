#include "ocean/tile_chunks.h"

#include <algorithm>
#include <string>

#include "common/error.h"

namespace squall::ocean::rpc {

namespace {
constexpr uint64_t kPieceHeaderBytes = 128;  // a FieldPiece's name, unit, grid, spacing, origin, tags
}

uint64_t chunk_payload_budget(uint64_t max_message_bytes) {
  const uint64_t reserve = std::min<uint64_t>(16384, max_message_bytes / 4);
  return max_message_bytes - reserve;
}

ChunkPlan plan_chunks(const std::vector<uint64_t>& row_bytes, const std::vector<uint32_t>& ny, uint64_t budget) {
  ChunkPlan plan(1);
  uint64_t left = budget;
  for (size_t f = 0; f < row_bytes.size(); ++f) {
    if (row_bytes[f] + kPieceHeaderBytes > budget)
      fail(Code::ResourceExhausted, "one row of output field " + std::to_string(f) + " needs " +
                                        std::to_string(row_bytes[f]) +
                                        " bytes, more than a message may carry under "
                                        "--max-message-bytes");
    for (uint32_t row = 0; row < ny[f];) {
      if (left < row_bytes[f] + kPieceHeaderBytes) {
        plan.emplace_back();
        left = budget;
      }
      uint32_t rows = uint32_t(std::min<uint64_t>(ny[f] - row, (left - kPieceHeaderBytes) / row_bytes[f]));
      plan.back().push_back({int(f), row, rows});
      left -= kPieceHeaderBytes + rows * row_bytes[f];
      row += rows;
    }
  }
  return plan;
}

void fill_chunk(squall::v1::GetTileResponse& frame, const ChunkPlan& plan, uint32_t index, uint32_t frame_index,
                squall::v1::TileChunk* chunk) {
  chunk->Clear();
  chunk->set_frame_index(frame_index);
  *chunk->mutable_time() = frame.time();
  chunk->set_chunk_index(index);
  chunk->set_chunk_count(uint32_t(plan.size()));
  if (index == 0) *chunk->mutable_stats() = frame.stats();
  for (const PieceRef& ref : plan[index]) {
    squall::v1::Field& full = *frame.mutable_fields(ref.field);
    const size_t row_bytes = size_t(full.nx()) * (full.dtype() == squall::v1::DTYPE_FLOAT16 ? 2 : 4);
    auto* piece = chunk->add_pieces();
    piece->set_row_offset(ref.row);
    piece->set_full_ny(full.ny());
    squall::v1::Field* f = piece->mutable_field();
    f->set_name(full.name());
    f->set_unit(full.unit());
    f->set_nx(full.nx());
    f->set_ny(ref.rows);
    *f->mutable_spacing() = full.spacing();
    *f->mutable_origin() = full.origin();
    f->mutable_origin()->set_y(full.origin().y() + ref.row * full.spacing().y());
    f->set_dtype(full.dtype());
    if (ref.row == 0 && ref.rows == full.ny())
      f->mutable_data()->swap(*full.mutable_data());  // whole field
    else
      f->set_data(full.data().substr(ref.row * row_bytes, ref.rows * row_bytes));
  }
}

}  // namespace squall::ocean::rpc
