#include "clouds/clouds_service.h"

#include <algorithm>
#include <map>
#include <optional>

#include "clouds/clouds_request.h"
#include "common/validate.h"
#include "rpc/metadata.h"
#include "rpc/streaming.h"

namespace squall::rpc {
namespace {

namespace v1 = squall::v1;
using namespace squall::clouds;
namespace req = squall::clouds::rpc;

// Memory a render's image holds while it runs, an estimate taken against --memory-budget: on the device,
// on the host and in the reply. A deep shadow map the render makes holds its own (CloudRenderer::render).
uint64_t image_working_bytes(const RenderSettings& settings) { return 3 * req::image_bytes(settings); }

// The image's and the deep shadow map's together.
uint64_t render_working_bytes(const RenderSettings& settings) {
  return image_working_bytes(settings) + clouds::shadow_map_bytes(settings);
}

// The times where a parameter of model_at() clamped at 0 reaches it (the pyroclastic amplitude, the
// advection time), sorted: between two of them every parameter is linear in t, and the advection is on or
// off throughout.
std::vector<double> clamp_times(const CloudModel& base, const Evolution& e) {
  std::vector<double> at;
  if (e.amplitude_rate != 0) at.push_back(-base.pyroclastic.amplitude / e.amplitude_rate);
  if (e.advection_rate != 0) at.push_back(-base.advection.time / e.advection_rate);
  std::sort(at.begin(), at.end());
  return at;
}

// The times, the request's model, then the frames' models before the stream takes a slot or sends a frame:
// within each stretch of times between clamp_times() (and at each of them) every bound the validation
// checks is monotone in t, so a frame is within bounds when the stretch's earliest and latest frames are.
void validate_frames(const CloudEngine& engine, const CloudModel& base, const Evolution& evolution,
                     const google::protobuf::RepeatedField<double>& times) {
  for (int i = 0; i < times.size(); ++i) validate::finite(validate::at("times", i), times[i]);
  engine.validate(base, "model");
  const std::vector<double> clamps = clamp_times(base, evolution);
  std::map<size_t, std::pair<int, int>> ends;  // a stretch's earliest and latest frames, by the stretch
  for (int i = 0; i < times.size(); ++i) {
    const auto below = std::lower_bound(clamps.begin(), clamps.end(), times[i]);
    const size_t stretch = 2 * size_t(below - clamps.begin()) + (below != clamps.end() && *below == times[i]);
    const auto it = ends.try_emplace(stretch, i, i).first;
    if (times[i] < times[it->second.first]) it->second.first = i;
    if (times[i] > times[it->second.second]) it->second.second = i;
  }
  for (const auto& [stretch, frames] : ends)
    for (int i : {frames.first, frames.second})
      engine.validate(model_at(base, evolution, times[i]), "model at " + validate::at("times", i));
}

}  // namespace

void CloudsService::start(EngineContext& context) {
  CloudEngineOptions options;
  options.sessions = context.sessions;
  options.max_advection_samples = context.gate.limits().max_advection_samples;
  engine_ = std::make_unique<CloudEngine>(context.runtime, context.gate, options);
}

std::vector<CapabilityGauge> CloudsService::gauges() const {
  if (!engine_) return {};
  return {{"squall_stored_volumes", "Cloud volumes stored on the server (BuildVolume with keep)",
           double(engine_->stored_count())},
          {"squall_stored_volume_bytes", "Host and device bytes of the stored cloud volumes",
           double(engine_->stored_bytes())}};
}

grpc::Status CloudsService::BuildVolume(grpc::ServerContext* context, const v1::BuildVolumeRequest* request,
                                        v1::BuildVolumeResponse* response) {
  return serve(*context, serving_, [&] {
    // Held through the build: the request's model lives on, and the build checks the model again.
    Slot mesh_memory =
        serving_.gate().acquire_memory("BuildVolume's meshes, read", req::mesh_read_bytes(request->model()));
    CloudModel model = req::model(request->model());
    const uint64_t peak = engine_->validate(model, "model");
    std::optional<CloudEngine::Place> place;  // a bad model is INVALID_ARGUMENT however full the sessions are
    if (request->keep()) place = engine_->place(proposed_session(*context), client_address(*context));
    Slot memory = serving_.gate().acquire_memory("BuildVolume's build", peak);
    auto volume = engine_->build(std::move(model), "model", cancellation(*context));
    mesh_memory.release();
    if (request->return_vdb()) {
      std::string vdb = write_vdb(volume->volume);
      serving_.gate().check_message_bytes("BuildVolumeResponse.vdb", vdb.size());
      response->set_vdb(std::move(vdb));
    }
    if (request->keep()) {
      if (context->IsCancelled())  // built for a caller that has gone: nobody would hold its id
        fail(Code::Cancelled, "the volume was built after the call ended (client gone or deadline passed)");
      announce_session(*context, engine_->keep(volume, std::move(*place), &memory));
    }
    req::fill_summary(*volume, response->mutable_summary());
    return grpc::Status::OK;
  });
}

// Each refusal names the step that drives the cost it counts. A pixel's march: the primary step, or with
// direct shadows the finer of it and the shadow step (each of its samples marches toward the lights). A
// deep shadow map node's: the shadow step (three primary steps when not given). The whole render: a
// pixel's, or with a deep shadow map the map's where its nodes cost more than the pixels.
void CloudsService::check_work(const clouds::DeviceVolume& volume, const clouds::RenderSettings& settings) const {
  const bool lit = !settings.lights.empty(), own_shadow_step = settings.shadow_step > 0;
  const bool direct = lit && settings.shadow == ShadowMode::Direct;
  const bool pixel_by_shadow_step = direct && own_shadow_step && settings.shadow_step < settings.step;
  auto step = [&](bool shadow_step) {
    return shadow_step ? std::pair{std::string("settings.shadow_step"), validate::number(settings.shadow_step)}
                       : std::pair{std::string("settings.step"), validate::number(settings.step)};
  };
  const clouds::SampleEstimate estimate = clouds::estimate_samples(volume, settings);
  const double map = estimate.per_map_node * estimate.map_nodes;  // of estimate.total, the rest the pixels'
  const bool by_map = map > estimate.total - map;
  const auto [total_field, total_value] = step(by_map ? own_shadow_step : pixel_by_shadow_step);
  serving_.gate().check_render_samples(total_field, total_value, estimate.total,
                                       by_map ? "a larger shadow step or a smaller shadow_map_size"
                                              : "a larger step, fewer pixels or sub-steps, or a deep shadow map");
  // A pixel's march, and a deep shadow map node's, runs to its end once started.
  auto check_one_march = [](const std::pair<std::string, std::string>& step, double samples, const char* what) {
    if (samples > clouds::kMaxSamplesPerPixel)
      fail(Code::ResourceExhausted, step.first + " = " + step.second + " makes an estimated " +
                                        validate::number(samples) + " density samples per " + what + ", more than " +
                                        validate::number(clouds::kMaxSamplesPerPixel) + " (a " + what +
                                        "'s march cannot be cancelled midway; a larger step costs less, down to "
                                        "a step per 8-voxel leaf crossed)");
  };
  check_one_march(step(pixel_by_shadow_step), estimate.per_pixel, "pixel");
  check_one_march(step(own_shadow_step), estimate.per_map_node, "deep shadow map node");
  clouds::check_march_resolution(volume, settings, "settings");
}

grpc::Status CloudsService::Render(grpc::ServerContext* context, const v1::RenderRequest* request,
                                   v1::RenderResponse* response) {
  return serve(*context, serving_, [&] {
    CloudEngine& clouds = *engine_;
    const Cancellation cancel = cancellation(*context);
    RenderSettings settings = req::settings(request->settings());
    clouds::validate(settings, "settings");
    serving_.gate().check_message_bytes("RenderResponse.image (ask for fewer pixels or wavelengths)",
                                        req::image_bytes(settings));
    serving_.gate().check_memory("Render's image and shadow map", render_working_bytes(settings));
    Slot memory = serving_.gate().acquire_memory("Render's image", image_working_bytes(settings)), model_memory;
    std::shared_ptr<StoredVolume> volume;
    if (request->has_model()) {
      Slot mesh_memory =  // held through the build, as BuildVolume's
          serving_.gate().acquire_memory("Render's meshes, read", req::mesh_read_bytes(request->model()));
      CloudModel model = req::model(request->model());
      const uint64_t peak = clouds.validate(model, "model");
      model_memory = serving_.gate().acquire_memory("Render's model, built", peak);
      volume = clouds.build(std::move(model), "model", cancel);
    } else {
      if (request->volume_id().empty())
        fail(Code::InvalidArgument, "volume_id is empty and no model is given: send one of them");
      volume = clouds.find(request->volume_id());
    }
    check_work(volume->device, settings);
    req::fill_image(clouds.render(*volume, settings, "settings", cancel), response->mutable_image());
    req::fill_summary(*volume, response->mutable_summary());
    return grpc::Status::OK;
  });
}

grpc::Status CloudsService::StreamEvolution(grpc::ServerContext* context, const v1::StreamEvolutionRequest* request,
                                            grpc::ServerWriter<v1::EvolutionFrame>* writer) {
  struct Stream {
    CloudModel base;
    Evolution evolution;
    RenderSettings settings;
    Slot memory;       // held for the whole stream
    Slot mesh_memory;  // the base model's meshes and a frame's copy of them, each read and checked
  };
  auto check = [&] {
    Slot mesh_memory =
        serving_.gate().acquire_memory("StreamEvolution's meshes, read", 2 * req::mesh_read_bytes(request->model()));
    Stream s{req::model(request->model()),
             req::evolution(request->evolution()),
             req::settings(request->settings()),
             {},
             std::move(mesh_memory)};
    clouds::validate(s.evolution, "evolution");
    clouds::validate(s.settings, "settings");
    serving_.gate().check_message_bytes("EvolutionFrame.image", req::image_bytes(s.settings));
    if (request->times_size() < 1 || request->times_size() > 1000)
      fail(Code::InvalidArgument, "times has " + std::to_string(request->times_size()) + " entries: must be 1 to 1000");
    validate_frames(*engine_, s.base, s.evolution, request->times());
    return s;
  };
  auto prepare = [&](Stream& s) {  // the frames' images and deep shadow maps, held for the whole stream
    s.memory = serving_.gate().acquire_memory("StreamEvolution's frames", render_working_bytes(s.settings));
  };
  return serve_stream(*context, serving_, "StreamEvolution", check, prepare, [&](StreamCall& call, const Stream& s) {
    const auto& [base, evolution, settings, memory, mesh_memory] = s;
    for (int i = 0; i < request->times_size(); ++i) {
      if (!call.live()) return;
      const double t = request->times(i);
      CloudModel model = model_at(base, evolution, t);
      const std::string field = "model at " + validate::at("times", i);
      Slot volume_memory =
          serving_.gate().acquire_memory("StreamEvolution's volume, built", engine_->validate(model, field));
      auto volume = engine_->build(std::move(model), field, call.cancellation());
      check_work(volume->device, settings);
      v1::EvolutionFrame frame;
      frame.set_time(t);
      req::fill_image(engine_->render(*volume, settings, "settings", call.cancellation(), &memory),
                      frame.mutable_image());
      req::fill_summary(*volume, frame.mutable_summary());
      if (request->include_vdb()) {
        std::string vdb = write_vdb(volume->volume);
        serving_.gate().check_message_bytes("EvolutionFrame.vdb", vdb.size() + req::image_bytes(settings));
        frame.set_vdb(std::move(vdb));
      }
      if (!call.write(*writer, frame)) return;
    }
  });
}

grpc::Status CloudsService::ReleaseVolume(grpc::ServerContext* context, const v1::ReleaseVolumeRequest* request,
                                          v1::ReleaseVolumeResponse*) {
  return serve(*context, serving_, [&] {
    engine_->release(request->volume_id());
    return grpc::Status::OK;
  });
}

}  // namespace squall::rpc
