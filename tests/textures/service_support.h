// What the Textures service tests share: one real squalld per test binary, the engine it runs (in this
// process, on the same device, for bit comparisons), streams read to the end, and small requests.
#pragma once

#include <grpcpp/grpcpp.h>

#include <string>
#include <vector>

#include "common/error.h"
#include "squall/v1/textures.grpc.pb.h"
#include "support/daemon.h"
#include "textures/texture_engine.h"

namespace squall::textures_test {

namespace v1 = squall::v1;

test::Daemon& daemon();
// The engine the daemon runs, in this process, on the same device.
textures::TextureEngine& engine();

struct Streamed {
  std::vector<v1::TextureFrame> frames;
  grpc::Status status;
};

// AdvectTexture read to its end.
Streamed advect(const v1::AdvectTextureRequest& request);
// The engine's code for a gRPC status code.
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

}  // namespace squall::textures_test
