#include "clouds/clouds_service.h"

#include <cmath>

#include "clouds/clouds_request.h"
#include "daemon/status.h"

namespace squall::rpc {
namespace {

namespace v1 = squall::v1;
using namespace squall::clouds;
namespace req = squall::clouds::rpc;

grpc::Status cancelled(const char* call) { return grpc::Status(grpc::StatusCode::CANCELLED, std::string(call) + " cancelled"); }

}  // namespace

CloudEngine& CloudsService::engine() {
  engines_.require_ready();
  engines_.clouds->evict_expired();
  return *engines_.clouds;
}

grpc::Status CloudsService::BuildVolume(grpc::ServerContext*, const v1::BuildVolumeRequest* request,
                                        v1::BuildVolumeResponse* response) {
  return guarded([&] {
    CloudEngine& clouds = engine();
    auto volume = clouds.build(req::model(request->model()), "model");
    if (request->return_vdb()) {
      std::string vdb = write_vdb(volume->volume);
      engines_.gate.check_message_bytes("BuildVolumeResponse.vdb", vdb.size());
      response->set_vdb(std::move(vdb));
    }
    if (request->keep()) clouds.keep(volume);
    req::fill_summary(*volume, response->mutable_summary());
    return grpc::Status::OK;
  });
}

grpc::Status CloudsService::Render(grpc::ServerContext* context, const v1::RenderRequest* request,
                                   v1::RenderResponse* response) {
  return guarded([&] {
    CloudEngine& clouds = engine();
    RenderSettings settings = req::settings(request->settings());
    validate(settings, "settings");
    engines_.gate.check_message_bytes("RenderResponse.image (ask for fewer pixels or wavelengths)", req::image_bytes(settings));
    std::shared_ptr<StoredVolume> volume;
    if (request->has_model()) {
      volume = clouds.build(req::model(request->model()), "model");
    } else {
      if (request->volume_id().empty())
        fail(Code::InvalidArgument, "volume_id is empty and no model is given: send one of them");
      volume = clouds.find(request->volume_id(), "volume_id");
    }
    if (context->IsCancelled()) return cancelled("Render");
    req::fill_image(clouds.render(*volume, settings, "settings"), response->mutable_image());
    req::fill_summary(*volume, response->mutable_summary());
    return grpc::Status::OK;
  });
}

grpc::Status CloudsService::StreamEvolution(grpc::ServerContext* context, const v1::StreamEvolutionRequest* request,
                                            grpc::ServerWriter<v1::EvolutionFrame>* writer) {
  return guarded([&] {
    CloudEngine& clouds = engine();
    Slot slot = engines_.gate.acquire_stream();  // released on every way out of this call
    CloudModel base = req::model(request->model());
    Evolution evolution = req::evolution(request->evolution());
    validate(evolution, "evolution");
    RenderSettings settings = req::settings(request->settings());
    validate(settings, "settings");
    engines_.gate.check_message_bytes("EvolutionFrame.image", req::image_bytes(settings));
    if (request->times_size() < 1 || request->times_size() > 1000)
      fail(Code::InvalidArgument, "times has " + std::to_string(request->times_size()) + " entries; 1..1000 are allowed");
    for (int i = 0; i < request->times_size(); ++i)
      if (!std::isfinite(request->times(i)))
        fail(Code::InvalidArgument, "times[" + std::to_string(i) + "] = " + std::to_string(request->times(i)) + " must be finite");
    for (double t : request->times()) {
      if (context->IsCancelled()) return cancelled("StreamEvolution");
      auto volume = clouds.build(model_at(base, evolution, t), "model");
      v1::EvolutionFrame frame;
      frame.set_time(t);
      req::fill_image(clouds.render(*volume, settings, "settings"), frame.mutable_image());
      req::fill_summary(*volume, frame.mutable_summary());
      if (request->include_vdb()) {
        std::string vdb = write_vdb(volume->volume);
        engines_.gate.check_message_bytes("EvolutionFrame.vdb", vdb.size() + req::image_bytes(settings));
        frame.set_vdb(std::move(vdb));
      }
      if (!writer->Write(frame)) return cancelled("StreamEvolution");
    }
    return grpc::Status::OK;
  });
}

grpc::Status CloudsService::ReleaseVolume(grpc::ServerContext*, const v1::ReleaseVolumeRequest* request,
                                          v1::ReleaseVolumeResponse*) {
  return guarded([&] {
    if (!engine().release(request->volume_id()))
      fail(Code::NotFound, "volume_id = \"" + request->volume_id() + "\" is not a stored volume");
    return grpc::Status::OK;
  });
}

}  // namespace squall::rpc
