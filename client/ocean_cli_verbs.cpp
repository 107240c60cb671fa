#include "client/ocean_cli_verbs.h"

#include <iostream>

#include "client/cli.h"
#include "client/cli_flags.h"
#include "client/ocean_cli_output.h"
#include "client/ocean_frames.h"
#include "squall/v1/ocean.grpc.pb.h"

namespace squall::cli::ocean {
namespace {

namespace v1 = squall::v1;

using client::check;

}  // namespace

int tile(client::Client& client, const Request& r) {
  if (r.out.empty()) throw UsageError("tile needs -o FILE.exr");
  require_extension(r.out, ".exr", "OpenEXR (its PNG preview beside it)");
  check_preview(r.out, r.preview);
  v1::GetTileRequest request;
  *request.mutable_tile() = r.tile;
  request.mutable_time()->set_seconds(r.time);
  for (auto o : r.outputs) request.add_outputs(o);
  request.set_dtype(r.dtype);
  v1::GetTileResponse response;
  auto stub = v1::Ocean::NewStub(client.channel());
  check(stub->GetTile(client.context().get(), request, &response), "Ocean.GetTile");
  write_tile(response, request, r.out, preview_path(r));
  std::cout << r.out << ": " << response.fields_size() << " channels, " << response.fields(0).nx() << " x "
            << response.fields(0).ny() << "\n";
  return kOk;
}

int stream(client::Client& client, const Request& r) {
  if (r.out.empty()) throw UsageError("stream needs -o DIR");
  if (!r.have_dt) throw UsageError("stream needs --dt SECONDS (> 0)");
  if (!r.have_frames || r.frames == 0) throw UsageError("stream needs --frames N (>= 1)");
  const OutputFolder folder(r.out);
  v1::StreamTilesRequest request;
  *request.mutable_tile() = r.tile;
  request.mutable_t0()->set_seconds(r.t0);
  request.set_dt(r.dt);
  request.set_frame_count(uint32_t(r.frames));
  for (auto o : r.outputs) request.add_outputs(o);
  request.set_dtype(r.dtype);
  auto stub = v1::Ocean::NewStub(client.channel());
  auto context = client.context("", double(r.frames));  // each frame gets --timeout
  auto reader = stub->StreamTiles(context.get(), request);
  client::ocean::FrameAssembler assembler;
  v1::TileChunk chunk;
  int written = 0;
  while (reader->Read(&chunk)) {
    auto frame = assembler.add(chunk);
    if (!frame) continue;
    write_tile(*frame, request, frame_path(r.out, chunk.frame_index()), "");
    ++written;
  }
  check(reader->Finish(), "Ocean.StreamTiles");
  std::cout << r.out << ": " << written << " frames\n";
  return kOk;
}

int sample(client::Client& client, const Request& r) {
  if (r.points.empty()) throw UsageError("sample needs --point X,Y or --points-file FILE");
  v1::SampleSurfaceRequest request;
  *request.mutable_tile() = r.tile;
  request.mutable_time()->set_seconds(r.time);
  request.set_invert_displacement(r.invert);
  for (auto [x, y] : r.points) {
    auto* p = request.add_points();
    p->set_x(x);
    p->set_y(y);
  }
  v1::SampleSurfaceResponse s;
  auto stub = v1::Ocean::NewStub(client.channel());
  check(stub->SampleSurface(client.context().get(), request, &s), "Ocean.SampleSurface");
  write_samples(std::cout, r, s);
  return kOk;
}

}  // namespace squall::cli::ocean
