// squall.v1.Textures over a TextureEngine. Requests are translated in textures_request.h and validated by
// the engine under the path "request" (AdvectInteractive: "control[n]"); each stream runs one advection,
// frame by frame. A velocity may follow the surface current of an eWave session or of an ocean tile, read
// from the daemon's eWave or ocean engine before each step, or be a procedural river baked on a grid.
// DeformTexture and DeformInteractive stream content-aware deformations of a texture.
#pragma once

#include <memory>
#include <string>

#include "ewave/ewave_engine.h"
#include "ocean/ocean_engine.h"
#include "rpc/capability.h"
#include "rpc/serving.h"
#include "squall/v1/textures.grpc.pb.h"
#include "textures/deform.h"
#include "textures/river.h"
#include "textures/texture_engine.h"
#include "textures/textures_request.h"

namespace squall::rpc {

class TexturesService final : public squall::v1::Textures::Service, public Capability {
 public:
  explicit TexturesService(ServingState& serving) : serving_(serving) {}

  grpc::Service& service() override { return *this; }
  const char* service_name() const override { return squall::v1::Textures::service_full_name(); }
  void start(EngineContext& context) override;

  // Holds a --max-streams slot; starts the advection (or resumes it from resume_state) and writes its
  // frames up to frame `frames - 1`, checking for cancellation before each; a failing frame ends the
  // stream with its status.
  grpc::Status AdvectTexture(grpc::ServerContext* context, const squall::v1::AdvectTextureRequest* request,
                             grpc::ServerWriter<squall::v1::TextureFrame>* writer) override;
  // Holds a --max-streams slot; reads one message, applies it (the first starts the advection), writes
  // the frames it asks for (blocking writes: gRPC flow control), then reads the next.
  grpc::Status AdvectInteractive(
      grpc::ServerContext* context,
      grpc::ServerReaderWriter<squall::v1::TextureFrame, squall::v1::TextureControl>* stream) override;
  grpc::Status BakeVelocity(grpc::ServerContext* context, const squall::v1::BakeVelocityRequest* request,
                            squall::v1::BakeVelocityReply* reply) override;

  // Content-aware deformation (deform_service.cpp). Holds a --max-streams slot; solves the flow (or
  // reuses a cached solve) and writes frames 0 .. frames - 1, checking for cancellation before each.
  grpc::Status DeformTexture(grpc::ServerContext* context, const squall::v1::DeformTextureRequest* request,
                             grpc::ServerWriter<squall::v1::DeformFrame>* writer) override;
  // Holds a --max-streams slot; reads one message, applies it (the first starts the deformation), writes
  // the frames it asks for, then reads the next.
  grpc::Status DeformInteractive(
      grpc::ServerContext* context,
      grpc::ServerReaderWriter<squall::v1::DeformFrame, squall::v1::DeformControl>* stream) override;

 private:
  struct Stream;  // one advection stream's state (textures_service.cpp)

  // The stream's velocity from the current it follows, read now: an eWave session's (NOT_FOUND naming the
  // field for an unknown id), or an ocean tile's over the step from `from` to from + dt, each checked as
  // read (validate_followed_current, validate_made_velocity). No-op otherwise.
  void follow(Stream& s, double from);
  // The current `velocity` (the request field at `path`) names, translated (req::followed); an ocean's layers
  // checked against the FFT backend's lengths (INVALID_ARGUMENT naming them).
  textures::rpc::FollowedCurrent followed(const squall::v1::VelocitySpec& velocity, const std::string& path);
  // The surface current of the eWave session `followed` names, of 2 x 2 cells or more, and of the grid of its
  // first read (noted in `followed`; ABORTED when it differs).
  SurfaceCurrent session_current(textures::rpc::FollowedCurrent& followed) const;
  // The river of `velocity` (the request field at `path`), if it is one, and its bake grid, validated into
  // the stream's river to bake.
  void check_river(const squall::v1::VelocitySpec& velocity, Stream& s, const std::string& path) const;
  // The stream's river to bake, if any, baked into its velocity (the rest of its spec validated before
  // check_river), the bake's memory reserved while it runs.
  void bake_river(Stream& s, const std::string& path);
  // The stream's spec validated (under `spec_path`) with a still velocity: the rest of a request whose
  // velocity is made later, a river's bake or a followed current's read, refused before that is done.
  void validate_beside_velocity(Stream& s, const std::string& spec_path) const;
  // The advection's next frame; with `refresh`, the followed current is read for its step first.
  textures::TextureFrame next_frame(Stream& s, textures::Advection& advection, bool refresh);
  // Message n of an AdvectInteractive stream applied to `s`: the first starts `advection`.
  void apply(const squall::v1::TextureControl& control, size_t n, Stream& s,
             std::unique_ptr<textures::Advection>& advection);

  ServingState& serving_;
  std::unique_ptr<textures::TextureEngine> engine_;
  std::unique_ptr<textures::RiverEngine> rivers_;
  std::unique_ptr<textures::DeformEngine> deform_;
  ewave::EWaveEngine* ewave_ = nullptr;  // the daemon's
  ocean::OceanEngine* ocean_ = nullptr;  // the daemon's
};

}  // namespace squall::rpc
