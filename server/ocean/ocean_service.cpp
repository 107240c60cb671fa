#include "ocean/ocean_service.h"

#include <future>

#include "common/field_codec.h"
#include "common/validate.h"
#include "ocean/ocean_request.h"
#include "ocean/shared_engine.h"
#include "ocean/tile_chunks.h"
#include "rpc/streaming.h"

namespace squall::rpc {
namespace {

namespace v1 = squall::v1;
using namespace squall::ocean::rpc;

constexpr int kMaxSamplePoints = 1000000;
constexpr uint64_t kSampleBytesPerPoint = 8 * 9;  // eight packed doubles
// What a SampleSurface call holds per point while it runs: the point, its sample, the reply's eight
// doubles and the reply serialized.
constexpr uint64_t kSampleWorkingBytesPerPoint =
    sizeof(ocean::Vec2) + sizeof(ocean::SurfaceSample) + 8 * sizeof(double) + kSampleBytesPerPoint;

// A validated tile request: the engine spec, the outputs in request order, and the reply's dtype.
struct TileJob {
  ocean::TileSpec spec;
  std::vector<v1::TileOutput> outputs;
  unsigned flags = 0;   // the outputs' Output groups
  unsigned planes = 0;  // the outputs themselves (kAllPlanes bits)
  v1::DType dtype = v1::DTYPE_FLOAT32;
  int64_t nx = 0, ny = 0;

  uint64_t row_bytes() const { return uint64_t(nx) * squall::field::bytes_per_value(dtype); }
  uint64_t frame_bytes() const { return outputs.size() * (row_bytes() * ny + 128) + 256; }
  // Memory a call holds while it runs, an estimate taken against --memory-budget: per frame the engine's
  // float fields, the reply and the engine's device buffers (ocean::tile_device_bytes), twice that for a
  // stream (it computes the next frame while writing one).
  uint64_t working_bytes(int frames) const {
    const uint64_t floats = outputs.size() * uint64_t(nx) * uint64_t(ny) * 4;
    return uint64_t(frames) * (floats + frame_bytes() + ocean::tile_device_bytes(spec, flags));
  }
};

TileJob tile_job(const ocean::OceanEngine& engine, const v1::TileSpec& tile,
                 const google::protobuf::RepeatedField<int>& outputs, v1::DType d, const LimitGate& gate) {
  TileJob job;
  job.spec = tile_spec(tile, gate);  // validated under "tile."
  engine.check_transforms(job.spec, "tile");
  job.outputs = squall::ocean::rpc::outputs(outputs);
  job.flags = output_flags(job.outputs);
  job.planes = output_planes(job.outputs);
  job.dtype = squall::field::dtype(d, "dtype");
  output_grid(job.spec, &job.nx, &job.ny);
  return job;
}

// One frame's reply, the outputs in request order, encoded from the engine's views (one copy of each
// plane, made after the device is let go). `cancel` is looked at in the engine and before each field;
// `spectra` is the call's reservation of the spectra it builds, from which a spectrum the engine keeps
// takes its bytes.
void tile_reply(ocean::OceanEngine& engine, const TileJob& job, double t, ocean::WhitecapState* whitecaps,
                const Cancellation& cancel, Slot& spectra, v1::GetTileResponse* reply) {
  const ocean::TileFields fields = engine.tile(job.spec, t, job.flags, whitecaps, cancel, job.planes, &spectra);
  reply->mutable_time()->set_seconds(t);
  reply->mutable_stats()->set_unresolved_slope_variance(fields.unresolved_slope_variance);
  fill_fields(fields, job.outputs, job.dtype, cancel, reply->mutable_fields());
}

ChunkPlan frame_plan(const TileJob& job, uint64_t max_message_bytes) {
  std::vector<uint64_t> row_bytes(job.outputs.size(), job.row_bytes());
  std::vector<uint32_t> ny(job.outputs.size(), uint32_t(job.ny));
  return plan_chunks(row_bytes, ny, chunk_payload_budget(max_message_bytes));
}

}  // namespace

void OceanService::start(EngineContext& context) { engine_ = &ocean::shared_engine(context); }

grpc::Status OceanService::GetTile(grpc::ServerContext* context, const v1::GetTileRequest* request,
                                   v1::GetTileResponse* response) {
  return serve(*context, serving_, [&] {
    TileJob job = tile_job(*engine_, request->tile(), request->outputs(), request->dtype(), serving_.gate());
    double t = sim_time("time.seconds", request->time().seconds());
    serving_.gate().check_message_bytes("GetTile reply (use StreamTiles, which splits frames)", job.frame_bytes());
    const uint64_t new_spectra = engine_->new_spectra_bytes(job.spec);
    Slot memory = serving_.gate().acquire_memory("GetTile's tile", job.working_bytes(1) + new_spectra);
    Slot spectra = memory.split(new_spectra);
    serving_.gate().top_up(spectra, "GetTile's spectra, built again",
                           [&] { return engine_->new_spectra_bytes(job.spec); });
    if (context->IsCancelled()) return grpc::Status(grpc::StatusCode::CANCELLED, "GetTile cancelled");
    tile_reply(*engine_, job, t, nullptr, cancellation(*context), spectra, response);
    return grpc::Status::OK;
  });
}

grpc::Status OceanService::StreamTiles(grpc::ServerContext* context, const v1::StreamTilesRequest* request,
                                       grpc::ServerWriter<v1::TileChunk>* writer) {
  struct Stream {
    TileJob job;
    double t0, dt;
    ChunkPlan plan;
    Slot memory;   // held for the whole stream
    Slot spectra;  // the spectra the next frame builds: a spectrum kept takes its bytes from here
  };
  auto check = [&] {
    TileJob job = tile_job(*engine_, request->tile(), request->outputs(), request->dtype(), serving_.gate());
    const double t0 = sim_time("t0.seconds", request->t0().seconds());
    const double dt = validate::positive("dt", request->dt());
    if (request->frame_count() > 0)  // the last frame's time, before the first frame is sent
      sim_time("t0 + (frame_count - 1) dt", t0 + double(request->frame_count() - 1) * dt);
    ChunkPlan plan = frame_plan(job, serving_.gate().limits().max_message_bytes);
    return Stream{std::move(job), t0, dt, std::move(plan), Slot(), Slot()};
  };
  auto prepare = [&](Stream& stream) {
    const uint64_t new_spectra = engine_->new_spectra_bytes(stream.job.spec);
    stream.memory = serving_.gate().acquire_memory("StreamTiles' frames", stream.job.working_bytes(2) + new_spectra);
    stream.spectra = stream.memory.split(new_spectra);
  };
  return serve_stream(*context, serving_, "StreamTiles", check, prepare, [&](StreamCall& call, Stream& stream) {
    const TileJob& job = stream.job;  // not a structured binding: lambdas below capture these
    const double t0 = stream.t0, dt = stream.dt;
    const ChunkPlan& plan = stream.plan;
    ocean::WhitecapState whitecaps;  // touched by one compute at a time: frame i + 1 starts after i ended
    auto time_of = [&](uint64_t frame) { return t0 + double(frame) * dt; };  // no accumulated rounding
    auto compute = [&](uint64_t frame) {
      v1::GetTileResponse reply;
      const double t = sim_time("t0 + frame_index dt", time_of(frame));  // an endless stream's end of time
      // A spectrum let go of since (another call needed the room) is built again, reserved anew.
      serving_.gate().top_up(stream.spectra, "StreamTiles' spectra, built again",
                             [&] { return engine_->new_spectra_bytes(job.spec); });
      tile_reply(*engine_, job, t, &whitecaps, call.cancellation(), stream.spectra, &reply);
      return reply;
    };
    const auto more = [&](uint64_t frame) { return request->frame_count() == 0 || frame < request->frame_count(); };
    // Pipelined: the engine computes frame i + 1 while frame i is encoded and written. An early return
    // waits for the pending frame (std::future's destructor) before the locals it uses go away.
    std::future<v1::GetTileResponse> next = std::async(std::launch::async, compute, 0);
    v1::TileChunk chunk;
    for (uint64_t frame = 0; more(frame); ++frame) {
      v1::GetTileResponse reply = next.get();
      if (!call.live()) return;
      if (more(frame + 1)) next = std::async(std::launch::async, compute, frame + 1);
      for (uint32_t c = 0; c < plan.size(); ++c) {  // a frame whole: live() is asked before the next one
        fill_chunk(reply, plan, c, uint32_t(frame), &chunk);
        if (!call.write(*writer, chunk)) return;
      }
    }
  });
}

grpc::Status OceanService::SampleSurface(grpc::ServerContext* context, const v1::SampleSurfaceRequest* request,
                                         v1::SampleSurfaceResponse* response) {
  return serve(*context, serving_, [&] {
    ocean::TileSpec spec = tile_spec(request->tile(), serving_.gate());
    engine_->check_transforms(spec, "tile");
    const double t = sim_time("time.seconds", request->time().seconds());
    const int n = request->points_size();
    if (n < 1 || n > kMaxSamplePoints)
      fail(Code::InvalidArgument,
           "points has " + std::to_string(n) + " entries: must be 1 to " + std::to_string(kMaxSamplePoints));
    serving_.gate().check_message_bytes("SampleSurface reply", uint64_t(n) * kSampleBytesPerPoint);
    const uint64_t new_spectra = engine_->new_spectra_bytes(spec);
    Slot memory = serving_.gate().acquire_memory(
        "SampleSurface's layers and points",
        ocean::sample_bytes(spec) + uint64_t(n) * kSampleWorkingBytesPerPoint + new_spectra);
    Slot spectra = memory.split(new_spectra);
    serving_.gate().top_up(spectra, "SampleSurface's spectra, built again",
                           [&] { return engine_->new_spectra_bytes(spec); });
    std::vector<ocean::Vec2> points(n);  // each checked finite by sample(), naming "points[i].x"
    for (int i = 0; i < n; ++i) points[i] = {request->points(i).x(), request->points(i).y()};
    const bool invert = request->invert_displacement();
    std::vector<ocean::SurfaceSample> samples =
        engine_->sample(spec, t, points, invert, cancellation(*context), &spectra);
    for (auto* field : {response->mutable_height(), response->mutable_displacement_x(),
                        response->mutable_displacement_y(), response->mutable_normal_x(), response->mutable_normal_y(),
                        response->mutable_normal_z(), response->mutable_source_x(), response->mutable_source_y()})
      field->Reserve(n);  // the eight doubles a point, no more
    for (int i = 0; i < n; ++i) {
      const auto& s = samples[i];
      response->add_height(s.height);
      response->add_displacement_x(s.displacement_x);
      response->add_displacement_y(s.displacement_y);
      response->add_normal_x(s.normal_x);
      response->add_normal_y(s.normal_y);
      response->add_normal_z(s.normal_z);
      response->add_source_x(s.source.x);
      response->add_source_y(s.source.y);
    }
    return grpc::Status::OK;
  });
}

}  // namespace squall::rpc
