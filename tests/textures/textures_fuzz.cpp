// libFuzzer harness: squall.v1.Textures' requests (AdvectTexture, BakeVelocity, DeformTexture) through
// the conversion and validation the service and its engines run before any device work
// (tests/support/fuzz.h).
#include "squall/v1/textures.pb.h"
#include "support/fuzz.h"
#include "textures/deform_request.h"
#include "textures/deform_validate.h"
#include "textures/river.h"
#include "textures/river_request.h"
#include "textures/texture_engine.h"
#include "textures/textures_request.h"

namespace {

namespace v1 = squall::v1;
using namespace squall;
namespace req = squall::textures::rpc;

const std::vector<test::RequestCheck> kChecks = {
    [](const std::string& bytes) {
      v1::AdvectTextureRequest r;
      if (!test::parse(bytes, &r)) return;
      LimitGate gate{Limits{}};
      Slot decoded;
      textures::validate_advect(req::spec(r, gate, decoded), gate, "request");
      req::planes(r.output());
      req::followed(r.velocity(), test::default_gate(), "request.velocity");
    },
    [](const std::string& bytes) {
      v1::BakeVelocityRequest r;
      if (!test::parse(bytes, &r)) return;
      textures::validate_river(req::river(r.river()), "request.river");
      textures::validate_bake_grid(req::bake_grid(r), test::default_gate(), "request");
    },
    [](const std::string& bytes) {
      v1::DeformTextureRequest r;
      if (!test::parse(bytes, &r)) return;
      LimitGate gate{Limits{}};
      Slot decoded;
      textures::validate_deform(req::deform_spec(r, gate, decoded), gate, "request");
      req::deform_planes(r, "request");
    },
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return squall::test::fuzz_requests(data, size, kChecks);
}
