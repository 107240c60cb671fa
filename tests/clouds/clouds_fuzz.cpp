// libFuzzer harness: squall.v1.Clouds' requests (BuildVolume's model, Render's settings and model,
// StreamEvolution's evolution) through the conversion and validation the service runs before it builds
// or renders anything (tests/support/fuzz.h).
#include "clouds/clouds_request.h"
#include "clouds/evolution.h"
#include "clouds/model.h"
#include "clouds/renderer.h"
#include "common/validate.h"
#include "squall/v1/clouds.pb.h"
#include "support/fuzz.h"

namespace {

namespace v1 = squall::v1;
using namespace squall;

void check_model(const v1::CloudModel& model) { clouds::validate(clouds::rpc::model(model), "model"); }

void check_settings(const v1::RenderSettings& settings) {
  clouds::validate(clouds::rpc::settings(settings), "settings");
}

const std::vector<test::RequestCheck> kChecks = {
    [](const std::string& bytes) {
      v1::BuildVolumeRequest r;
      if (test::parse(bytes, &r)) check_model(r.model());
    },
    [](const std::string& bytes) {
      v1::RenderRequest r;
      if (!test::parse(bytes, &r)) return;
      check_settings(r.settings());
      if (r.has_model()) check_model(r.model());
    },
    [](const std::string& bytes) {
      v1::StreamEvolutionRequest r;
      if (!test::parse(bytes, &r)) return;
      check_settings(r.settings());
      const clouds::Evolution evolution = clouds::rpc::evolution(r.evolution());
      clouds::validate(evolution, "evolution");
      const clouds::CloudModel base = clouds::rpc::model(r.model());
      clouds::validate(base, "model");
      for (int i = 0; i < r.times_size(); ++i) {
        const std::string at = validate::at("times", i);
        clouds::validate(clouds::model_at(base, evolution, validate::finite(at, r.times(i))), "model at " + at);
      }
    },
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return squall::test::fuzz_requests(data, size, kChecks);
}
