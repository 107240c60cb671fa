#include "service_support.h"

#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "client/client.h"
#include "common/field_codec.h"
#include "support/process.h"
#include "support/test_runtime.h"
#include "textures/deform_request.h"
#include "textures/textures_request.h"

namespace squall::textures_test {

test::Daemon& daemon() {
  static test::Daemon d;
  return d;
}

textures::TextureEngine& engine() {
  static LimitGate gate{Limits{}};
  static textures::TextureEngine e(test::runtime(), gate);
  return e;
}

textures::AdvectSpec translated(const v1::AdvectTextureRequest& request, const Limits& limits) {
  LimitGate gate{limits};
  Slot decoded;
  return textures::rpc::spec(request, gate, decoded);
}

textures::DeformSpec translated(const v1::DeformTextureRequest& request, const Limits& limits) {
  LimitGate gate{limits};
  Slot decoded;
  return textures::rpc::deform_spec(request, gate, decoded);
}

Streamed advect(const v1::AdvectTextureRequest& request, const std::string& address, double timeout) {
  return read_stream<v1::TextureFrame>(
      [&](v1::Textures::Stub& service, grpc::ClientContext* c) { return service.AdvectTexture(c, request); }, address,
      timeout);
}

void expect_daemon_stops(const std::string& what) {
  std::this_thread::sleep_for(std::chrono::seconds(1));
  const double before = daemon().process().cpu_seconds();
  std::this_thread::sleep_for(std::chrono::seconds(2));
  EXPECT_LT(daemon().process().cpu_seconds() - before, 0.5) << "squalld kept " << what;
}

Code code_of(grpc::StatusCode code) {
  switch (code) {
    case grpc::StatusCode::INVALID_ARGUMENT: return Code::InvalidArgument;
    case grpc::StatusCode::RESOURCE_EXHAUSTED: return Code::ResourceExhausted;
    case grpc::StatusCode::NOT_FOUND: return Code::NotFound;
    case grpc::StatusCode::FAILED_PRECONDITION: return Code::FailedPrecondition;
    case grpc::StatusCode::UNAVAILABLE: return Code::Unavailable;
    case grpc::StatusCode::ABORTED: return Code::Aborted;
    default: return Code::Internal;
  }
}

void throw_status(const grpc::Status& status) {
  if (!status.ok())
    throw Error(code_of(status.error_code()), std::to_string(int(status.error_code())) + ": " + status.error_message());
}

void advect_or_throw(const v1::AdvectTextureRequest& request) { throw_status(advect(request).status); }

v1::Field float_field(const std::string& name, uint32_t nx, uint32_t ny, const std::vector<float>& values) {
  v1::Field f;
  field::encode({name, "1", nx, ny, 0, v1::DTYPE_FLOAT32}, values, &f);
  return f;
}

void all_planes(v1::AdvectTextureRequest& r) {
  for (auto p :
       {v1::TEXTURE_PLANE_FINAL, v1::TEXTURE_PLANE_RAW, v1::TEXTURE_PLANE_WEIGHT_SUM, v1::TEXTURE_PLANE_WEIGHT_SQ_SUM,
        v1::TEXTURE_PLANE_COVERAGE, v1::TEXTURE_PLANE_LAYER, v1::TEXTURE_PLANE_UV})
    r.mutable_output()->add_planes(p);
}

v1::AdvectTextureRequest noise_request(uint32_t frames) {
  v1::AdvectTextureRequest r;
  r.set_method(v1::TEXTURE_METHOD_LAGRANGIAN_GRIDS);
  auto* v = r.mutable_velocity()->mutable_named();
  v->set_kind(v1::AnalyticVelocity::KIND_ROTATION);
  v->set_angular_velocity(0.8);
  auto* noise = r.mutable_texture()->mutable_noise();
  noise->set_bands(3);
  noise->set_time_varying(true);
  r.mutable_texture()->set_final_function(v1::FINAL_FUNCTION_SUM_BANDS);
  r.mutable_output()->set_width(64);
  r.mutable_output()->set_height(64);
  r.set_t0(0.25);
  r.set_dt(0.05);
  r.set_frames(frames);
  r.set_seed(7);
  all_planes(r);
  return r;
}

v1::TextureControl start(v1::AdvectTextureRequest request, uint32_t frames) {
  request.set_frames(0);
  v1::TextureControl c;
  *c.mutable_start() = request;
  c.set_frames(frames);
  return c;
}

v1::TextureControl more(uint32_t frames) {
  v1::TextureControl c;
  c.set_frames(frames);
  return c;
}

}  // namespace squall::textures_test
