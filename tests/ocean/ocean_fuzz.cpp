// libFuzzer harness: squall.v1.Ocean's requests (GetTile, StreamTiles, SampleSurface) through the
// conversion and validation the service runs before any device work (tests/support/fuzz.h).
#include "common/field_codec.h"
#include "common/validate.h"
#include "ocean/ocean_request.h"
#include "squall/v1/ocean.pb.h"
#include "support/fuzz.h"

namespace {

namespace v1 = squall::v1;
using namespace squall;

void tile_job(const v1::TileSpec& tile, const google::protobuf::RepeatedField<int>& outputs, v1::DType dtype) {
  ocean::TileSpec spec = ocean::rpc::tile_spec(tile, test::default_gate());
  ocean::rpc::output_flags(ocean::rpc::outputs(outputs));
  field::dtype(dtype, "dtype");
  int64_t nx = 0, ny = 0;
  ocean::rpc::output_grid(spec, &nx, &ny);
}

const std::vector<test::RequestCheck> kChecks = {
    [](const std::string& bytes) {
      v1::GetTileRequest r;
      if (!test::parse(bytes, &r)) return;
      tile_job(r.tile(), r.outputs(), r.dtype());
      validate::finite("time.seconds", r.time().seconds());
    },
    [](const std::string& bytes) {
      v1::StreamTilesRequest r;
      if (!test::parse(bytes, &r)) return;
      tile_job(r.tile(), r.outputs(), r.dtype());
      validate::finite("t0.seconds", r.t0().seconds());
      validate::positive("dt", r.dt());
    },
    [](const std::string& bytes) {
      v1::SampleSurfaceRequest r;
      if (!test::parse(bytes, &r)) return;
      ocean::rpc::tile_spec(r.tile(), test::default_gate());
      for (int i = 0; i < r.points_size(); ++i) validate::finite(validate::at("points", i) + ".x", r.points(i).x());
    },
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return squall::test::fuzz_requests(data, size, kChecks);
}
