// What the Textures service tests share: one real squalld per test binary, the engine it runs (in this
// process, on the same device, for bit comparisons), streams read to the end, and small requests.
#pragma once

#include <grpcpp/grpcpp.h>

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "client/client.h"
#include "common/error.h"
#include "common/limits.h"
#include "squall/v1/textures.grpc.pb.h"
#include "support/daemon.h"
#include "textures/deform.h"
#include "textures/texture_engine.h"

namespace squall::textures_test {

namespace v1 = squall::v1;

test::Daemon& daemon();
// The engine the daemon runs, in this process, on the same device.
textures::TextureEngine& engine();

// A server stream read to its end: its frames and its status.
template <typename Frame>
struct StreamedOf {
  std::vector<Frame> frames;
  grpc::Status status;
};
using Streamed = StreamedOf<v1::TextureFrame>;

// Opens a server stream on a fresh client of the daemon at `address` (by default the binary's) with a
// deadline of `timeout` s (open(service, context) makes the call) and reads it to its end.
template <typename Frame, typename Open>
StreamedOf<Frame> read_stream(const Open& open, const std::string& address = daemon().address(), double timeout = 300) {
  client::Client client({address, timeout, ""});
  auto service = v1::Textures::NewStub(client.channel());
  auto context = client.context();
  auto reader = open(*service, context.get());
  StreamedOf<Frame> s;
  for (Frame frame; reader->Read(&frame);) s.frames.push_back(frame);
  s.status = reader->Finish();
  return s;
}

// AdvectTexture read to its end (on the daemon at `address`, under a deadline of `timeout` s).
Streamed advect(const v1::AdvectTextureRequest& request, const std::string& address = daemon().address(),
                double timeout = 300);
// A request translated as the service translates it, under `limits` (the decoded image's memory given
// back once translated).
textures::AdvectSpec translated(const v1::AdvectTextureRequest& request, const Limits& limits = {});
textures::DeformSpec translated(const v1::DeformTextureRequest& request, const Limits& limits = {});

// The engine's code for a gRPC status code.
// After a call that expired: squalld, given a second to notice, spends under 0.5 s of CPU in the next
// two (it stopped `what`, the expired call's work).
void expect_daemon_stops(const std::string& what);

Code code_of(grpc::StatusCode code);
// A failed stream's status as the engine error it carries, for test::expect_error.
void throw_status(const grpc::Status& status);
void advect_or_throw(const v1::AdvectTextureRequest& request);

// A float32 Field of nx x ny values (unit "1").
v1::Field float_field(const std::string& name, uint32_t nx, uint32_t ny, const std::vector<float>& values);
// Every plane of the frames (final, raw, the four auxiliary ones), in the engine's order.
void all_planes(v1::AdvectTextureRequest& r);
// Lagrangian grids, 3 bands of flow noise (SUM_BANDS) under a solid rotation, 64 x 64 pixels, every plane.
v1::AdvectTextureRequest noise_request(uint32_t frames);

// A bidirectional call (AdvectInteractive, DeformInteractive): write a message, read the frames it asks for,
// and so on (the server reads the next message only once these are written).
template <typename Control, typename Frame>
class InteractiveCall {
 public:
  using Stream = grpc::ClientReaderWriter<Control, Frame>;
  using Open = std::function<std::unique_ptr<Stream>(v1::Textures::Stub&, grpc::ClientContext*)>;

  explicit InteractiveCall(const Open& open, const std::string& address = daemon().address())
      : client_({address, 300, ""}),
        service_(v1::Textures::NewStub(client_.channel())),
        context_(client_.context()),
        stream_(open(*service_, context_.get())) {}

  // Sends `control` and reads `frames` frames; false when the stream ended before (see finish()).
  bool send(const Control& control, uint32_t frames) {
    if (!stream_->Write(control)) return false;
    for (uint32_t k = 0; k < frames; ++k) {
      Frame frame;
      if (!stream_->Read(&frame)) return false;
      frames_.push_back(frame);
    }
    return true;
  }

  grpc::Status finish() {
    stream_->WritesDone();
    for (Frame frame; stream_->Read(&frame);) frames_.push_back(frame);
    return stream_->Finish();
  }

  const std::vector<Frame>& frames() const { return frames_; }

 private:
  client::Client client_;
  std::unique_ptr<v1::Textures::Stub> service_;
  std::unique_ptr<grpc::ClientContext> context_;
  std::unique_ptr<Stream> stream_;
  std::vector<Frame> frames_;
};

struct Interactive : InteractiveCall<v1::TextureControl, v1::TextureFrame> {
  explicit Interactive(const std::string& address = daemon().address()) : InteractiveCall(&open, address) {}
  static std::unique_ptr<Stream> open(v1::Textures::Stub& textures, grpc::ClientContext* context) {
    return textures.AdvectInteractive(context);
  }
};

// The first message of an AdvectInteractive call: `request` (its frames cleared), then `frames` frames.
v1::TextureControl start(v1::AdvectTextureRequest request, uint32_t frames);
// A message that only asks for `frames` more frames.
v1::TextureControl more(uint32_t frames);

}  // namespace squall::textures_test
