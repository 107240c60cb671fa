// libFuzzer harness: squall.v1.EWave's requests (CreateSession's config, Step's inputs on a 64 x 48
// session, Restore's state bytes) through the conversion and validation the service and the engine run
// before any device work (tests/support/fuzz.h).
#include "common/field_codec.h"
#include "ewave/ewave_request.h"
#include "ewave/ewave_session.h"
#include "squall/v1/ewave.pb.h"
#include "support/fuzz.h"

namespace {

namespace v1 = squall::v1;
using namespace squall;

// The config of the session a Step goes to.
const ewave::EWaveConfig& session_config() {
  static const ewave::EWaveConfig config = [] {
    v1::EWaveConfig c;
    c.set_nx(64);
    c.set_ny(48);
    c.set_dx(0.1);
    return ewave::rpc::config(c, test::default_gate());
  }();
  return config;
}

const std::vector<test::RequestCheck> kChecks = {
    [](const std::string& bytes) {
      v1::EWaveCreateSessionRequest r;
      if (test::parse(bytes, &r)) ewave::rpc::config(r.config(), test::default_gate());
    },
    [](const std::string& bytes) {
      v1::EWaveStepRequest r;
      if (!test::parse(bytes, &r)) return;
      ewave::rpc::outputs(r.inputs());
      field::dtype(r.inputs().dtype(), "inputs.dtype");
      ewave::rpc::inputs(r.inputs(), session_config(), test::default_gate());
    },
    [](const std::string& bytes) {
      v1::EWaveRestoreRequest r;
      if (!test::parse(bytes, &r)) return;
      ewave::validate(ewave::EWaveSession::config_from_state(r.state(), test::default_gate()), &test::default_gate());
    },
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return squall::test::fuzz_requests(data, size, kChecks);
}
