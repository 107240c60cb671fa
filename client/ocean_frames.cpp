#include "client/ocean_frames.h"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/reflection.h>

#include <sstream>
#include <stdexcept>

#include "server/common/field_codec.h"

namespace squall::client::ocean {
namespace {

using google::protobuf::FieldDescriptor;
using google::protobuf::Message;

squall::v1::Field* find_or_add(squall::v1::GetTileResponse& frame, const squall::v1::FieldPiece& piece) {
  for (auto& f : *frame.mutable_fields())
    if (f.name() == piece.field().name()) return &f;
  if (piece.row_offset() != 0)
    throw std::runtime_error("stream: field " + piece.field().name() + " starts at row " +
                             std::to_string(piece.row_offset()) + ", expected 0");
  auto* f = frame.add_fields();
  *f = piece.field();
  f->clear_data();
  f->set_ny(piece.full_ny());
  return f;
}

void append_piece(squall::v1::GetTileResponse& frame, squall::v1::FieldPiece& piece) {
  squall::v1::Field* f = find_or_add(frame, piece);
  const size_t row_bytes = size_t(f->nx()) * squall::field::bytes_per_value(f->dtype(), f->name() + ".dtype");
  const size_t rows_so_far = f->data().size() / row_bytes;
  if (piece.row_offset() != rows_so_far || piece.field().nx() != f->nx() ||
      piece.field().data().size() != piece.field().ny() * row_bytes || rows_so_far + piece.field().ny() > f->ny())
    throw std::runtime_error("stream: piece of " + f->name() + " at row " + std::to_string(piece.row_offset()) +
                             " does not continue the " + std::to_string(rows_so_far) + " rows received");
  if (f->data().empty())
    f->mutable_data()->swap(*piece.mutable_field()->mutable_data());  // no copy
  else
    f->mutable_data()->append(piece.field().data());
}

// "squall.<path>" = value for every field of `message`, recursively (unset optionals are left out).
void add_attributes(const Message& message, const std::string& path, Image& image) {
  const auto* descriptor = message.GetDescriptor();
  const auto* reflection = message.GetReflection();
  for (int i = 0; i < descriptor->field_count(); ++i) {
    const FieldDescriptor* fd = descriptor->field(i);
    std::string name = path + "." + fd->name();
    if (fd->is_repeated()) {
      int n = reflection->FieldSize(message, fd);
      for (int k = 0; k < n; ++k) {
        std::string item = name + "[" + std::to_string(k) + "]";
        if (fd->cpp_type() == FieldDescriptor::CPPTYPE_MESSAGE)
          add_attributes(reflection->GetRepeatedMessage(message, fd, k), item, image);
        else if (fd->cpp_type() == FieldDescriptor::CPPTYPE_ENUM)
          image.attributes.emplace_back(item, reflection->GetRepeatedEnum(message, fd, k)->name());
        else if (fd->cpp_type() == FieldDescriptor::CPPTYPE_DOUBLE)
          image.attributes.emplace_back(item, std::to_string(reflection->GetRepeatedDouble(message, fd, k)));
      }
      continue;
    }
    if (fd->has_presence() && !reflection->HasField(message, fd)) continue;
    std::ostringstream value;
    value.precision(17);
    switch (fd->cpp_type()) {
      case FieldDescriptor::CPPTYPE_MESSAGE: add_attributes(reflection->GetMessage(message, fd), name, image); continue;
      case FieldDescriptor::CPPTYPE_ENUM: value << reflection->GetEnum(message, fd)->name(); break;
      case FieldDescriptor::CPPTYPE_DOUBLE: value << reflection->GetDouble(message, fd); break;
      case FieldDescriptor::CPPTYPE_FLOAT: value << reflection->GetFloat(message, fd); break;
      case FieldDescriptor::CPPTYPE_UINT32: value << reflection->GetUInt32(message, fd); break;
      case FieldDescriptor::CPPTYPE_UINT64: value << reflection->GetUInt64(message, fd); break;
      case FieldDescriptor::CPPTYPE_INT32: value << reflection->GetInt32(message, fd); break;
      case FieldDescriptor::CPPTYPE_INT64: value << reflection->GetInt64(message, fd); break;
      case FieldDescriptor::CPPTYPE_BOOL: value << (reflection->GetBool(message, fd) ? "true" : "false"); break;
      case FieldDescriptor::CPPTYPE_STRING: value << reflection->GetString(message, fd); break;
    }
    image.attributes.emplace_back(name, value.str());
  }
}

}  // namespace

std::optional<squall::v1::GetTileResponse> FrameAssembler::add(squall::v1::TileChunk& chunk) {
  if (chunk.chunk_count() == 0 || chunk.chunk_index() >= chunk.chunk_count())
    throw std::runtime_error("stream: chunk " + std::to_string(chunk.chunk_index()) + " of " +
                             std::to_string(chunk.chunk_count()));
  if (chunk.chunk_index() != next_chunk_ || (next_chunk_ > 0 && chunk.frame_index() != frame_index_))
    throw std::runtime_error("stream: got chunk " + std::to_string(chunk.chunk_index()) + " of frame " +
                             std::to_string(chunk.frame_index()) + ", expected chunk " + std::to_string(next_chunk_) +
                             " of frame " + std::to_string(frame_index_));
  if (next_chunk_ == 0) {
    if (started_ && chunk.frame_index() != frame_index_ + 1)
      throw std::runtime_error("stream: frame " + std::to_string(chunk.frame_index()) + " follows frame " +
                               std::to_string(frame_index_));
    frame_ = {};
    frame_index_ = chunk.frame_index();
    started_ = true;
    *frame_.mutable_time() = chunk.time();
    *frame_.mutable_stats() = chunk.stats();
  }
  for (auto& piece : *chunk.mutable_pieces()) append_piece(frame_, piece);
  if (++next_chunk_ < chunk.chunk_count()) return std::nullopt;
  next_chunk_ = 0;
  for (const auto& f : frame_.fields())
    if (f.data().size() !=
        squall::field::value_count(f) * squall::field::bytes_per_value(f.dtype(), f.name() + ".dtype"))
      throw std::runtime_error("stream: frame " + std::to_string(frame_index_) + " ended with field " + f.name() +
                               " incomplete");
  return std::move(frame_);
}

std::vector<float> values(const squall::v1::Field& field) {
  return squall::field::decode(field, field.name().empty() ? std::string("field") : field.name());
}

Image tile_image(const squall::v1::GetTileResponse& tile, const google::protobuf::Message& request) {
  Image image;
  add_attributes(request, "squall.request", image);
  for (const auto& f : tile.fields()) {
    if (image.channels.empty()) image.nx = int(f.nx()), image.ny = int(f.ny());
    if (int(f.nx()) != image.nx || int(f.ny()) != image.ny)
      throw std::runtime_error("field " + f.name() + " is not on the grid of the first field");
    image.channels.push_back({f.name(), values(f)});
    std::ostringstream s;
    s.precision(17);
    s << f.unit() << "; spacing " << f.spacing().x() << " " << f.spacing().y() << " m; origin " << f.origin().x() << " "
      << f.origin().y() << " m; sent as " << squall::v1::DType_Name(f.dtype());
    image.attributes.emplace_back("squall.field." + f.name(), s.str());
  }
  client::add_time_attribute(image, tile.time().seconds());
  std::ostringstream v;
  v.precision(17);
  v << tile.stats().unresolved_slope_variance();
  image.attributes.emplace_back("squall.stats.unresolved_slope_variance", v.str());
  return image;
}

}  // namespace squall::client::ocean
