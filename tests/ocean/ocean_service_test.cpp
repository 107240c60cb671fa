// squall.v1.Ocean for real: squalld started on a free localhost port, called through gRPC and the CLI,
// its answers compared with the in-process OceanEngine on the same device (bit for bit).
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfStringAttribute.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <thread>

#include "client/client.h"
#include "client/ocean_frames.h"
#include "common/error.h"
#include "common/float16.h"
#include "ocean/ocean_engine.h"
#include "ocean/ocean_request.h"
#include "ocean/ocean_service.h"
#include "support/daemon.h"
#include "support/in_process.h"
#include "support/test_runtime.h"
#include "support/worst.h"

namespace squall {
namespace {

namespace v1 = squall::v1;

using test::Daemon;
const std::string kSquall = test::squall_path();

constexpr uint64_t kMaxCells = 300000;  // --max-grid-cells of the shared daemon: 512^2 fits, 1024^2 does not

// One daemon for most tests: VkFFT like the in-process engine, one stream slot.
Daemon& daemon() {
  static Daemon d({"--fft", "vkfft", "--max-streams", "1", "--max-grid-cells", std::to_string(kMaxCells)});
  return d;
}

// The in-process engine on this test's runtime (same device, same kernels, same FFT backend).
ocean::OceanEngine& engine() {
  static auto* e = new ocean::OceanEngine(test::runtime(), test::fft());
  return *e;
}

struct Call {
  std::unique_ptr<client::Client> client;
  std::unique_ptr<v1::Ocean::Stub> stub;
  std::unique_ptr<grpc::ClientContext> context;
};

Call call(const std::string& address, double timeout = 120) {
  Call c;
  c.client = std::make_unique<client::Client>(client::ClientOptions{address, timeout, ""});
  c.stub = v1::Ocean::NewStub(c.client->channel());
  c.context = c.client->context();
  return c;
}

// Two overlapping layers, choppy, 128^2 output: every code path of the tile at test size.
v1::TileSpec tile_spec() {
  v1::TileSpec t;
  auto* a = t.add_layers();
  a->set_extent_x(200);
  a->set_extent_y(160);
  a->set_nx(128);
  a->set_ny(96);
  a->set_spectrum(v1::SPECTRUM_MODEL_JONSWAP);
  a->set_spreading(v1::SPREADING_MODEL_MITSUYASU);
  a->set_dispersion(v1::DISPERSION_MODEL_DEEP);
  a->set_wind_speed(12);
  a->set_wind_direction(0.3);
  a->set_fetch(50000);
  a->set_seed(7);
  auto* b = t.add_layers();
  *b = *a;
  b->set_extent_x(50);
  b->set_extent_y(40);
  b->set_nx(64);
  b->set_ny(64);
  b->set_spectrum(v1::SPECTRUM_MODEL_PIERSON_MOSKOWITZ);
  b->set_spreading(v1::SPREADING_MODEL_VON_MISES);
  b->set_dispersion(v1::DISPERSION_MODEL_COMBINED);
  b->set_depth(30);
  b->set_drift_x(0.5);
  t.set_b_correction(true);
  t.set_choppiness(0.8);
  t.set_whitecap_threshold(0.9);  // J- of this sea dips below 0.9 in places: some foam in every frame
  return t;
}

const std::vector<v1::TileOutput> kAllOutputs = {
    v1::TILE_OUTPUT_HEIGHT,   v1::TILE_OUTPUT_DISPLACEMENT_X, v1::TILE_OUTPUT_DISPLACEMENT_Y, v1::TILE_OUTPUT_SLOPE_X,
    v1::TILE_OUTPUT_SLOPE_Y,  v1::TILE_OUTPUT_NORMAL_X,       v1::TILE_OUTPUT_NORMAL_Y,       v1::TILE_OUTPUT_NORMAL_Z,
    v1::TILE_OUTPUT_JACOBIAN, v1::TILE_OUTPUT_JACOBIAN_MINUS, v1::TILE_OUTPUT_JACOBIAN_PLUS,  v1::TILE_OUTPUT_WHITECAP};

v1::GetTileRequest tile_request(double t, v1::DType dtype = v1::DTYPE_FLOAT32) {
  v1::GetTileRequest r;
  *r.mutable_tile() = tile_spec();
  r.mutable_time()->set_seconds(t);
  for (auto o : kAllOutputs) r.add_outputs(o);
  r.set_dtype(dtype);
  return r;
}

// GetTile's status, its reply in `response`.
grpc::Status get_tile(const std::string& address, const v1::GetTileRequest& request, v1::GetTileResponse* response) {
  Call c = call(address);
  return c.stub->GetTile(c.context.get(), request, response);
}

v1::GetTileResponse get_tile(const std::string& address, const v1::GetTileRequest& request) {
  v1::GetTileResponse response;
  const grpc::Status status = get_tile(address, request, &response);
  EXPECT_TRUE(status.ok()) << status.error_message();
  return response;
}

// What the service should send for `fields`, computed in this process with the service's own encoder.
v1::GetTileResponse expected_reply(const ocean::TileFields& fields, v1::DType dtype) {
  v1::GetTileResponse r;
  for (auto o : kAllOutputs) ocean::rpc::fill_field(fields, o, dtype, r.add_fields());
  return r;
}

ocean::TileSpec engine_spec(const v1::TileSpec& tile) { return ocean::rpc::tile_spec(tile, LimitGate(Limits{})); }

TEST(OceanService, GetTileReturnsEveryFieldAsTheInProcessEngineBitForBit) {
  v1::GetTileResponse got = get_tile(daemon().address(), tile_request(3.25));
  ASSERT_EQ(got.fields_size(), int(kAllOutputs.size()));
  EXPECT_EQ(got.time().seconds(), 3.25);
  ocean::TileFields local = engine().tile(engine_spec(tile_spec()), 3.25, ocean::kAllOutputs);
  v1::GetTileResponse want = expected_reply(local, v1::DTYPE_FLOAT32);
  const char* names[] = {"height",   "displacement_x", "displacement_y", "slope_x",        "slope_y",       "normal_x",
                         "normal_y", "normal_z",       "jacobian",       "jacobian_minus", "jacobian_plus", "whitecap"};
  for (int i = 0; i < got.fields_size(); ++i) {
    const v1::Field& f = got.fields(i);
    EXPECT_EQ(f.name(), names[i]);
    EXPECT_EQ(f.nx(), 128u);  // the first layer's grid
    EXPECT_EQ(f.ny(), 96u);
    EXPECT_DOUBLE_EQ(f.spacing().x(), 200.0 / 128);
    EXPECT_DOUBLE_EQ(f.spacing().y(), 160.0 / 96);
    EXPECT_EQ(f.dtype(), v1::DTYPE_FLOAT32);
    std::vector<float> v = client::ocean::values(f);
    int non_finite = 0;
    for (float x : v) non_finite += !std::isfinite(x);
    EXPECT_EQ(non_finite, 0) << f.name();
    EXPECT_TRUE(f.data() == want.fields(i).data()) << f.name() << " differs from the in-process engine";
  }
  EXPECT_EQ(got.stats().unresolved_slope_variance(), local.unresolved_slope_variance);
  EXPECT_GT(got.stats().unresolved_slope_variance(), 0);
  // Not a constant field: the waves are there (rms height of a 12 m/s JONSWAP sea is metres, not zero).
  std::vector<float> h = client::ocean::values(got.fields(0));
  double s = 0;
  for (float x : h) s += double(x) * x;
  EXPECT_GT(std::sqrt(s / h.size()), 0.1);
}

TEST(OceanService, Float16FieldsAreTheRoundedFloat32Fields) {
  v1::GetTileResponse half = get_tile(daemon().address(), tile_request(1.0, v1::DTYPE_FLOAT16));
  v1::GetTileResponse full = get_tile(daemon().address(), tile_request(1.0, v1::DTYPE_FLOAT32));
  ASSERT_EQ(half.fields_size(), full.fields_size());
  for (int i = 0; i < half.fields_size(); ++i) {
    EXPECT_EQ(half.fields(i).dtype(), v1::DTYPE_FLOAT16);
    ASSERT_EQ(half.fields(i).data().size(), full.fields(i).data().size() / 2);
    std::vector<float> f = client::ocean::values(full.fields(i));
    std::string want;
    f16::append_half_bytes(f.data(), f.size(), &want);
    EXPECT_TRUE(half.fields(i).data() == want) << half.fields(i).name();
  }
}

// Reads a whole StreamTiles call into frames (checking frame order and message sizes on the way).
struct StreamResult {
  std::vector<v1::GetTileResponse> frames;
  grpc::Status status;
  size_t chunks = 0;
  size_t largest_message = 0;
};

StreamResult stream(const std::string& address, const v1::StreamTilesRequest& request) {
  StreamResult out;
  Call c = call(address);
  auto reader = c.stub->StreamTiles(c.context.get(), request);
  client::ocean::FrameAssembler assembler;
  v1::TileChunk chunk;
  while (reader->Read(&chunk)) {
    ++out.chunks;
    out.largest_message = std::max(out.largest_message, chunk.ByteSizeLong());
    if (auto frame = assembler.add(chunk)) out.frames.push_back(std::move(*frame));
  }
  out.status = reader->Finish();
  return out;
}

v1::StreamTilesRequest stream_request(double t0, double dt, uint32_t frames) {
  v1::StreamTilesRequest r;
  *r.mutable_tile() = tile_spec();
  r.mutable_t0()->set_seconds(t0);
  r.set_dt(dt);
  r.set_frame_count(frames);
  for (auto o : kAllOutputs) r.add_outputs(o);
  return r;
}

// N frames in order at t0 + i dt, each equal to the in-process engine fed the same frames with one
// whitecap state (so the whitecap map evolves along the stream exactly as the engine's does).
TEST(OceanService, StreamDeliversFramesInOrderWithTheWhitecapStateCarried) {
  StreamResult r = stream(daemon().address(), stream_request(2.0, 0.5, 4));
  ASSERT_TRUE(r.status.ok()) << r.status.error_message();
  ASSERT_EQ(r.frames.size(), 4u);
  EXPECT_EQ(r.chunks, 4u);  // 12 fields of 48 KiB fit one 64 MiB message
  ocean::TileSpec spec = engine_spec(tile_spec());
  ocean::WhitecapState whitecaps;
  double foam_before = -1;
  for (int i = 0; i < 4; ++i) {
    const double t = 2.0 + 0.5 * i;
    EXPECT_EQ(r.frames[i].time().seconds(), t);
    v1::GetTileResponse want =
        expected_reply(engine().tile(spec, t, ocean::kAllOutputs, &whitecaps), v1::DTYPE_FLOAT32);
    for (int f = 0; f < want.fields_size(); ++f)
      EXPECT_TRUE(r.frames[i].fields(f).data() == want.fields(f).data())
          << "frame " << i << " " << want.fields(f).name();
    // Whitecaps decay rather than vanish: a point marked in frame i - 1 and not re-marked keeps
    // exp(-dt / T) = exp(-0.5 / 4) of its value, so total foam never drops below that fraction.
    std::vector<float> w = client::ocean::values(r.frames[i].fields(11));
    double foam = 0;
    int decaying = 0;  // 0 < W < 1: marked in an earlier frame, not in this one
    for (float x : w) foam += x, decaying += x > 0 && x < 1;
    EXPECT_GT(foam, 0) << "frame " << i;
    // The first frame starts from an empty map; later ones hold decaying foam.
    EXPECT_EQ(decaying > 0, i > 0) << "frame " << i << ": " << decaying << " decaying cells";
    if (foam_before >= 0) {
      EXPECT_GE(foam, foam_before * std::exp(-0.5 / 4) - 1e-3);
    }
    foam_before = foam;
  }
  // Height etc. do not depend on history: frame 2 equals GetTile at its t.
  v1::GetTileResponse single = get_tile(daemon().address(), tile_request(3.0));
  for (int f = 0; f < 11; ++f) EXPECT_TRUE(r.frames[2].fields(f).data() == single.fields(f).data()) << f;
}

// With --max-message-bytes = 64 KiB a 48 KiB field cannot share a message: frames come in chunks, none
// larger than the limit, and reassemble to what GetTile returns on an unlimited daemon.
TEST(OceanService, LargeFramesAreChunkedAndReassembleToGetTile) {
  Daemon small({"--fft", "vkfft", "--max-message-bytes", "65536"});
  v1::StreamTilesRequest request = stream_request(5.0, 1.0, 2);
  StreamResult r = stream(small.address(), request);
  ASSERT_TRUE(r.status.ok()) << r.status.error_message();
  ASSERT_EQ(r.frames.size(), 2u);
  EXPECT_GE(r.chunks, 2u * 12);
  EXPECT_LE(r.largest_message, 65536u);
  v1::GetTileResponse whole = get_tile(daemon().address(), tile_request(5.0));
  for (int f = 0; f < 11; ++f) EXPECT_TRUE(r.frames[0].fields(f).data() == whole.fields(f).data()) << f;
  // GetTile itself cannot answer there: RESOURCE_EXHAUSTED, pointing at StreamTiles.
  Call c = call(small.address());
  v1::GetTileResponse response;
  grpc::Status status = c.stub->GetTile(c.context.get(), tile_request(5.0), &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_NE(status.error_message().find("StreamTiles"), std::string::npos) << status.error_message();
}

// The bytes a GetTile of `outputs` (one 2048^2 layer, a 64^2 output) asks the memory budget for, read from its
// refusal under a budget of one byte.
uint64_t tile_request_bytes(const v1::GetTileRequest& request) {
  Limits limits;
  limits.memory_budget = 1;
  test::InProcess<rpc::OceanService> server(limits);
  v1::GetTileResponse response;
  const grpc::Status status = get_tile(server.address(), request, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
  const size_t open = status.error_message().find("GetTile's tile (");
  return open == std::string::npos ? 0 : std::stoull(status.error_message().substr(open + 16));
}

// A GetTile whose own kept spectrum the budget takes back to make room for its tile builds it again
// reserved. The budget holds the height's tile with the spectrum (N1 bytes), and the full tile alone, not
// with the spectrum (N2): after the height's tile kept it, the full tile is refused naming the rebuild.
// Before, its reservation evicted the kept spectrum, and the rebuild on the device went uncounted.
TEST(OceanService, ATileWhoseKeptSpectrumIsTakenBackReservesItsRebuild) {
  v1::GetTileRequest height;
  *height.mutable_tile() = tile_spec();
  height.mutable_tile()->mutable_layers()->DeleteSubrange(1, 1);
  v1::LayerSpec& layer = *height.mutable_tile()->mutable_layers(0);
  layer.set_nx(2048), layer.set_ny(2048), layer.set_extent_x(2000), layer.set_extent_y(2000);
  height.mutable_tile()->mutable_output()->set_nx(64);
  height.mutable_tile()->mutable_output()->set_ny(64);
  height.add_outputs(v1::TILE_OUTPUT_HEIGHT);
  v1::GetTileRequest all = height;
  all.clear_outputs();
  for (auto o : kAllOutputs) all.add_outputs(o);
  const uint64_t spectrum = 2048ull * 2048 * 6 * sizeof(float), n1 = tile_request_bytes(height),
                 n2 = tile_request_bytes(all);
  ASSERT_GT(n2, n1);
  ASSERT_LT(n2 - n1, 2 * spectrum);  // the full tile alone fits the budget between them
  Limits limits;
  limits.memory_budget = (n1 + n2) / 2;
  test::InProcess<rpc::OceanService> server(limits);
  v1::GetTileResponse response;
  ASSERT_TRUE(get_tile(server.address(), height, &response).ok());
  EXPECT_EQ(server.serving().gate().cached_memory_bytes(), spectrum);
  const grpc::Status status = get_tile(server.address(), all, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
  EXPECT_NE(status.error_message().find("GetTile's spectra, built again"), std::string::npos) << status.error_message();
}

// A bad request is refused for what it is, INVALID_ARGUMENT, even when every stream slot is taken: it is
// validated before it asks for a slot.
TEST(OceanService, ABadStreamRequestIsInvalidEvenWhenTheStreamsAreFull) {
  Limits limits;
  limits.max_streams = 1;
  test::InProcess<rpc::OceanService> server(limits);
  auto stub = v1::Ocean::NewStub(server.channel());
  grpc::ClientContext open;
  auto held = stub->StreamTiles(&open, stream_request(0.0, 1.0, 0));  // endless
  v1::TileChunk chunk;
  ASSERT_TRUE(held->Read(&chunk));
  v1::StreamTilesRequest bad = stream_request(0.0, -1.0, 2);
  grpc::ClientContext refused;
  auto refused_stream = stub->StreamTiles(&refused, bad);
  while (refused_stream->Read(&chunk)) {
  }
  grpc::Status status = refused_stream->Finish();
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
  EXPECT_NE(status.error_message().find("dt = -1"), std::string::npos) << status.error_message();
  grpc::ClientContext full;
  auto full_stream = stub->StreamTiles(&full, stream_request(0.0, 1.0, 2));
  while (full_stream->Read(&chunk)) {
  }
  EXPECT_EQ(full_stream->Finish().error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  open.TryCancel();
  while (held->Read(&chunk)) {
  }
  EXPECT_EQ(held->Finish().error_code(), grpc::StatusCode::CANCELLED);
}

v1::SampleSurfaceRequest sample_request(const std::vector<std::pair<double, double>>& points, bool invert,
                                        const v1::TileSpec& tile, double t) {
  v1::SampleSurfaceRequest request;
  *request.mutable_tile() = tile;
  request.mutable_time()->set_seconds(t);
  request.set_invert_displacement(invert);
  for (auto [x, y] : points) {
    auto* p = request.add_points();
    p->set_x(x);
    p->set_y(y);
  }
  return request;
}

grpc::Status sample(const std::string& address, const v1::SampleSurfaceRequest& request,
                    v1::SampleSurfaceResponse* response) {
  Call c = call(address);
  return c.stub->SampleSurface(c.context.get(), request, response);
}

v1::SampleSurfaceResponse sample(const std::vector<std::pair<double, double>>& points, bool invert,
                                 const v1::TileSpec& tile, double t) {
  v1::SampleSurfaceResponse response;
  const grpc::Status status = sample(daemon().address(), sample_request(points, invert, tile, t), &response);
  EXPECT_TRUE(status.ok()) << status.error_message();
  return response;
}

// A request naming some fields of a group (normal_z of the normals), in any order, gets those fields, the
// same as in a request for every output (which transforms the displaced channel layout: float rounding).
TEST(OceanService, SomeFieldsOfAGroupAreThoseOfTheWholeTile) {
  v1::GetTileRequest all = tile_request(3.0), some = all;
  some.clear_outputs();
  some.add_outputs(v1::TILE_OUTPUT_NORMAL_Z), some.add_outputs(v1::TILE_OUTPUT_HEIGHT);
  v1::GetTileResponse whole = get_tile(daemon().address(), all), part = get_tile(daemon().address(), some);
  ASSERT_EQ(part.fields_size(), 2);
  const std::vector<std::pair<int, int>> pairs = {{0, 7}, {1, 0}};  // (part, whole) field indices
  for (auto [p, w] : pairs) {
    EXPECT_EQ(part.fields(p).name(), whole.fields(w).name());
    auto a = client::ocean::values(part.fields(p)), b = client::ocean::values(whole.fields(w));
    ASSERT_EQ(a.size(), b.size());
    double worst = 0, scale = 0;
    for (size_t i = 0; i < a.size(); ++i)
      worst = squall::test::worse(worst, double(std::abs(a[i] - b[i]))),
      scale = std::max(scale, double(std::abs(b[i])));
    EXPECT_LT(worst, 1e-5 * scale) << part.fields(p).name();
  }
}

// At the tile's grid points (also one period away) the samples are the tile's values; with
// invert_displacement, the query at a displaced point finds the grid point it came from.
TEST(OceanService, SampleSurfaceAtGridPointsEqualsTheTile) {
  v1::TileSpec one = tile_spec();
  one.mutable_layers()->DeleteSubrange(1, 1);  // one layer: its grid is the output grid
  v1::GetTileRequest request = tile_request(4.0);
  *request.mutable_tile() = one;
  v1::GetTileResponse tile = get_tile(daemon().address(), request);
  auto field = [&](int i) { return client::ocean::values(tile.fields(i)); };
  auto h = field(0), dx = field(1), dy = field(2), nx = field(5), ny = field(6), nz = field(7);
  const double sx = 200.0 / 128, sy = 160.0 / 96;
  const std::vector<std::pair<int, int>> cells = {{0, 0}, {17, 5}, {127, 95}, {64, 33}};
  std::vector<std::pair<double, double>> points;
  for (auto [i, j] : cells) points.emplace_back(i * sx, j * sy);
  points.emplace_back(17 * sx + 200, 5 * sy - 160);  // one period away from cell (17, 5)
  v1::SampleSurfaceResponse s = sample(points, false, one, 4.0);
  ASSERT_EQ(s.height_size(), int(points.size()));
  for (size_t p = 0; p < points.size(); ++p) {
    auto [i, j] = cells[p < cells.size() ? p : 1];
    size_t at = size_t(i) + 128 * size_t(j);
    EXPECT_NEAR(s.height(p), h[at], 1e-5 * (1 + std::abs(h[at]))) << p;
    EXPECT_NEAR(s.displacement_x(p), dx[at], 1e-5) << p;
    EXPECT_NEAR(s.displacement_y(p), dy[at], 1e-5) << p;
    EXPECT_NEAR(s.normal_x(p), nx[at], 1e-5) << p;
    EXPECT_NEAR(s.normal_y(p), ny[at], 1e-5) << p;
    EXPECT_NEAR(s.normal_z(p), nz[at], 1e-5) << p;
    EXPECT_DOUBLE_EQ(s.source_x(p), points[p].first);
  }
  // Inverse: query where grid point (17, 5) lands; the answer is that grid point's surface.
  const size_t at = 17 + 128 * 5;
  v1::SampleSurfaceResponse inv = sample({{17 * sx + dx[at], 5 * sy + dy[at]}}, true, one, 4.0);
  EXPECT_NEAR(inv.source_x(0), 17 * sx, 1e-3);
  EXPECT_NEAR(inv.source_y(0), 5 * sy, 1e-3);
  EXPECT_NEAR(inv.height(0), h[at], 1e-3);
}

struct BadCase {
  const char* what;
  std::function<void(v1::GetTileRequest&)> mutate;
  grpc::StatusCode code;
  const char* field;  // must appear in the message
};

TEST(OceanService, BadInputIsRejectedNamingTheFieldAndTheDaemonKeepsServing) {
  const double nan = std::nan("");
  std::vector<BadCase> cases = {
      {"NaN wind", [&](auto& r) { r.mutable_tile()->mutable_layers(0)->set_wind_speed(nan); },
       grpc::StatusCode::INVALID_ARGUMENT, "tile.layers[0].wind_speed = nan"},
      {"negative wind", [](auto& r) { r.mutable_tile()->mutable_layers(1)->set_wind_speed(-3); },
       grpc::StatusCode::INVALID_ARGUMENT, "tile.layers[1].wind_speed = -3"},
      {"negative fetch", [](auto& r) { r.mutable_tile()->mutable_layers(0)->set_fetch(-1); },
       grpc::StatusCode::INVALID_ARGUMENT, "tile.layers[0].fetch = -1"},
      {"zero grid", [](auto& r) { r.mutable_tile()->mutable_layers(0)->set_nx(0); }, grpc::StatusCode::INVALID_ARGUMENT,
       "tile.layers[0].nx = 0"},
      {"odd grid", [](auto& r) { r.mutable_tile()->mutable_layers(0)->set_ny(33); }, grpc::StatusCode::INVALID_ARGUMENT,
       "tile.layers[0].ny"},
      {"oversize grid",
       [](auto& r) {
         r.mutable_tile()->mutable_layers(0)->set_nx(1024), r.mutable_tile()->mutable_layers(0)->set_ny(1024);
       },
       grpc::StatusCode::RESOURCE_EXHAUSTED,
       "tile.layers[0].nx * tile.layers[0].ny = 1048576 cells exceeds --max-grid-cells"},
      {"oversize output",
       [](auto& r) {
         r.mutable_tile()->mutable_output()->set_nx(2048), r.mutable_tile()->mutable_output()->set_ny(2048);
       },
       grpc::StatusCode::RESOURCE_EXHAUSTED, "tile.output.nx * tile.output.ny"},
      {"unknown spectrum", [](auto& r) { r.mutable_tile()->mutable_layers(0)->set_spectrum(v1::SpectrumModel(99)); },
       grpc::StatusCode::INVALID_ARGUMENT, "tile.layers[0].spectrum = 99"},
      {"unspecified spreading",
       [](auto& r) { r.mutable_tile()->mutable_layers(0)->set_spreading(v1::SPREADING_MODEL_UNSPECIFIED); },
       grpc::StatusCode::INVALID_ARGUMENT, "tile.layers[0].spreading = 0"},
      {"unknown dispersion",
       [](auto& r) { r.mutable_tile()->mutable_layers(1)->set_dispersion(v1::DispersionModel(-4)); },
       grpc::StatusCode::INVALID_ARGUMENT, "tile.layers[1].dispersion = -4"},
      {"no depth for combined dispersion", [](auto& r) { r.mutable_tile()->mutable_layers(1)->set_depth(0); },
       grpc::StatusCode::INVALID_ARGUMENT, "tile.layers[1].depth = 0"},
      {"infinite choppiness", [](auto& r) { r.mutable_tile()->set_choppiness(INFINITY); },
       grpc::StatusCode::INVALID_ARGUMENT, "tile.choppiness = inf"},
      {"zero decay time", [](auto& r) { r.mutable_tile()->set_whitecap_decay_time(0); },
       grpc::StatusCode::INVALID_ARGUMENT, "tile.whitecap_decay_time = 0"},
      {"no layers", [](auto& r) { r.mutable_tile()->clear_layers(); }, grpc::StatusCode::INVALID_ARGUMENT,
       "tile.layers has 0 entries"},
      {"NaN time", [&](auto& r) { r.mutable_time()->set_seconds(nan); }, grpc::StatusCode::INVALID_ARGUMENT,
       "time.seconds = nan"},
      {"no outputs", [](auto& r) { r.clear_outputs(); }, grpc::StatusCode::INVALID_ARGUMENT, "outputs is empty"},
      {"unknown output", [](auto& r) { r.add_outputs(v1::TileOutput(77)); }, grpc::StatusCode::INVALID_ARGUMENT,
       "outputs[12] = 77"},
      {"unknown dtype", [](auto& r) { r.set_dtype(v1::DType(9)); }, grpc::StatusCode::INVALID_ARGUMENT, "dtype = 9"},
  };
  for (const auto& bad : cases) {
    v1::GetTileRequest request = tile_request(1.0);
    bad.mutate(request);
    Call c = call(daemon().address());
    v1::GetTileResponse response;
    grpc::Status status = c.stub->GetTile(c.context.get(), request, &response);
    EXPECT_EQ(status.error_code(), bad.code) << bad.what << ": " << status.error_message();
    EXPECT_NE(status.error_message().find(bad.field), std::string::npos) << bad.what << ": " << status.error_message();
  }
  // dt <= 0 and NaN dt for StreamTiles; a NaN point for SampleSurface.
  for (double dt : {0.0, -1.0, nan}) {
    v1::StreamTilesRequest request = stream_request(0, dt, 3);
    StreamResult r = stream(daemon().address(), request);
    EXPECT_EQ(r.status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << dt;
    EXPECT_EQ(r.status.error_message().rfind("dt = ", 0), 0u) << r.status.error_message();
    EXPECT_TRUE(r.frames.empty());
  }
  {
    v1::SampleSurfaceRequest request;
    *request.mutable_tile() = tile_spec();
    request.add_points()->set_x(1);
    request.add_points()->set_y(nan);
    Call c = call(daemon().address());
    v1::SampleSurfaceResponse response;
    grpc::Status status = c.stub->SampleSurface(c.context.get(), request, &response);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_NE(status.error_message().find("points[1].y = nan"), std::string::npos) << status.error_message();
  }
  EXPECT_TRUE(daemon().running());
  v1::GetTileResponse fine = get_tile(daemon().address(), tile_request(1.0));
  EXPECT_EQ(fine.fields_size(), 12);
}

// `call` on a squalld of each memory budget: refused under `tight` (RESOURCE_EXHAUSTED naming `what`), served
// under `roomy`.
void refused_then_served(uint64_t tight, uint64_t roomy, const std::string& what,
                         const std::function<grpc::Status(const std::string& address)>& call) {
  for (const auto& [budget, code] :
       {std::pair{tight, grpc::StatusCode::RESOURCE_EXHAUSTED}, std::pair{roomy, grpc::StatusCode::OK}}) {
    test::Daemon d({"--memory-budget", std::to_string(budget)});
    const grpc::Status status = call(d.address());
    EXPECT_EQ(status.error_code(), code) << budget << ": " << status.error_message();
    if (!status.ok()) {
      EXPECT_NE(status.error_message().find(what), std::string::npos) << status.error_message();
    }
  }
}

// A tile whose layer's spectrum is not kept builds it (6 floats a mode) beside its own buffers: a 2048^2
// layer's is 101 MB, sampled onto 64^2 output cells (34 MB of buffers), refused under a 96 MiB budget and
// served under 256 MiB.
TEST(OceanService, ASpectrumToBuildCountsInTheMemoryBudget) {
  v1::GetTileRequest request;
  auto* layer = request.mutable_tile()->add_layers();
  *layer = tile_spec().layers(0);
  layer->set_nx(2048), layer->set_ny(2048);
  layer->set_extent_x(2000), layer->set_extent_y(2000);
  request.mutable_tile()->mutable_output()->set_nx(64);
  request.mutable_tile()->mutable_output()->set_ny(64);
  request.add_outputs(v1::TILE_OUTPUT_HEIGHT);
  refused_then_served(96ull << 20, 256ull << 20, "GetTile's tile", [&](const std::string& address) {
    v1::GetTileResponse response;
    return get_tile(address, request, &response);
  });
}

// A sample holds about 200 bytes a point while it runs (the point, its sample, the reply's eight doubles and
// the reply serialized): 400000 points of a small layer, 80 MB, are refused under a 32 MiB budget and served
// under 256 MiB.
TEST(OceanService, SamplePointsCountInTheMemoryBudget) {
  const std::vector<std::pair<double, double>> points(400000, {1.5, 2.5});
  const v1::SampleSurfaceRequest request = sample_request(points, false, tile_spec(), 1.0);
  refused_then_served(32ull << 20, 256ull << 20, "SampleSurface's layers and points", [&](const std::string& address) {
    v1::SampleSurfaceResponse response;
    const grpc::Status status = sample(address, request, &response);
    if (status.ok()) {
      EXPECT_EQ(response.height_size(), 400000);
    }
    return status;
  });
}

// --max-streams 1: a second stream is refused while the first runs (RESOURCE_EXHAUSTED); cancelling the
// endless first stream frees the slot (the server notices the cancellation between frames).
TEST(OceanService, StreamLimitAndCancellation) {
  Call first = call(daemon().address());
  v1::StreamTilesRequest endless = stream_request(0, 0.1, 0);
  auto reader = first.stub->StreamTiles(first.context.get(), endless);
  v1::TileChunk chunk;
  ASSERT_TRUE(reader->Read(&chunk));
  ASSERT_TRUE(reader->Read(&chunk));
  EXPECT_EQ(chunk.frame_index(), 1u);

  StreamResult second = stream(daemon().address(), stream_request(0, 0.1, 2));
  EXPECT_EQ(second.status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << second.status.error_message();
  EXPECT_NE(second.status.error_message().find("--max-streams"), std::string::npos) << second.status.error_message();

  first.context->TryCancel();
  while (reader->Read(&chunk)) {
  }
  EXPECT_EQ(reader->Finish().error_code(), grpc::StatusCode::CANCELLED);
  StreamResult third;
  for (int attempt = 0; attempt < 100; ++attempt) {  // the server releases the slot when it sees the cancel
    third = stream(daemon().address(), stream_request(0, 0.1, 2));
    if (third.status.error_code() != grpc::StatusCode::RESOURCE_EXHAUSTED) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  EXPECT_TRUE(third.status.ok()) << third.status.error_message();
  EXPECT_EQ(third.frames.size(), 2u);
}

std::vector<std::string> cli_args(const std::vector<std::string>& verb_args) {
  std::vector<std::string> argv = {kSquall, "--address", daemon().address(), "ocean"};
  argv.insert(argv.end(), verb_args.begin(), verb_args.end());
  return argv;
}

// `squall ocean tile` writes an EXR that OpenEXR reads back: one FLOAT channel per output, the values
// of GetTile for the same spec, and the request in the header.
TEST(OceanCli, TileWritesAnExrThatOpenExrReadsBack) {
  std::string dir = test::temp_dir("ocean-cli");
  std::string out;
  std::vector<std::string> flags = {
      "--extent",     "300,200",      "--grid",       "64,32", "--spectrum", "pierson-moskowitz",
      "--spreading",  "pierson-cos2", "--wind-speed", "9",     "--seed",     "42",
      "--choppiness", "0.5",          "--time",       "2.5",   "--outputs",  "height,jacobian_minus,normal_z"};
  std::vector<std::string> args = {"tile"};
  args.insert(args.end(), flags.begin(), flags.end());
  args.insert(args.end(), {"-o", dir + "/tile.exr"});
  ASSERT_EQ(test::run(cli_args(args), &out), 0) << out;
  EXPECT_TRUE(std::filesystem::exists(dir + "/tile.png")) << out;

  Imf::InputFile file((dir + "/tile.exr").c_str());
  const Imf::Header& header = file.header();
  auto attribute = [&](const std::string& name) {
    const auto* a = header.findTypedAttribute<Imf::StringAttribute>(name);
    return a ? a->value() : std::string("(missing)");
  };
  EXPECT_EQ(attribute("squall.request.tile.layers[0].wind_speed"), "9");
  EXPECT_EQ(attribute("squall.request.tile.layers[0].spectrum"), "SPECTRUM_MODEL_PIERSON_MOSKOWITZ");
  EXPECT_EQ(attribute("squall.request.tile.choppiness"), "0.5");
  EXPECT_EQ(attribute("squall.request.time.seconds"), "2.5");
  EXPECT_EQ(attribute("squall.request.outputs[1]"), "TILE_OUTPUT_JACOBIAN_MINUS");
  EXPECT_NE(attribute("squall.field.height").find("m; spacing 4.6875 6.25 m"), std::string::npos)
      << attribute("squall.field.height");
  Imath::Box2i window = header.dataWindow();
  ASSERT_EQ(window.max.x + 1, 64);
  ASSERT_EQ(window.max.y + 1, 32);

  // The same request through gRPC: the pixels equal the field values.
  v1::GetTileRequest request;
  auto* layer = request.mutable_tile()->add_layers();
  layer->set_extent_x(300), layer->set_extent_y(200), layer->set_nx(64), layer->set_ny(32);
  layer->set_spectrum(v1::SPECTRUM_MODEL_PIERSON_MOSKOWITZ), layer->set_spreading(v1::SPREADING_MODEL_PIERSON_COS2);
  layer->set_dispersion(v1::DISPERSION_MODEL_DEEP), layer->set_wind_speed(9), layer->set_seed(42);
  layer->set_fetch(100000), layer->set_depth(100), layer->set_capillary_length(0.0027);  // the CLI's defaults
  request.mutable_tile()->set_choppiness(0.5);
  request.mutable_time()->set_seconds(2.5);
  for (auto o : {v1::TILE_OUTPUT_HEIGHT, v1::TILE_OUTPUT_JACOBIAN_MINUS, v1::TILE_OUTPUT_NORMAL_Z})
    request.add_outputs(o);
  v1::GetTileResponse tile = get_tile(daemon().address(), request);
  Imf::FrameBuffer frame;
  std::vector<std::vector<float>> pixels(3, std::vector<float>(64 * 32));
  for (int c = 0; c < 3; ++c) {
    const std::string& name = tile.fields(c).name();
    ASSERT_NE(header.channels().findChannel(name), nullptr) << name;
    EXPECT_EQ(header.channels().findChannel(name)->type, Imf::FLOAT);
    frame.insert(name, Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(pixels[c].data()), 4, 4 * 64));
  }
  file.setFrameBuffer(frame);
  file.readPixels(0, 31);
  for (int c = 0; c < 3; ++c) EXPECT_TRUE(pixels[c] == client::ocean::values(tile.fields(c))) << tile.fields(c).name();
}

TEST(OceanCli, StreamWritesANumberedSequenceAndSamplePrintsCsv) {
  std::string dir = test::temp_dir("ocean-cli-stream");
  std::string out;
  ASSERT_EQ(test::run(cli_args({"stream", "--grid", "32", "--dt", "0.25", "--frames", "3", "--outputs",
                                "height,whitecap", "-o", dir}),
                      &out),
            0)
      << out;
  for (const char* name : {"frame_00000.exr", "frame_00001.exr", "frame_00002.exr"})
    EXPECT_TRUE(std::filesystem::exists(dir + "/" + name)) << name << "\n" << out;
  EXPECT_FALSE(std::filesystem::exists(dir + "/frame_00003.exr"));

  ASSERT_EQ(test::run(cli_args({"sample", "--grid", "32", "--point", "0,0", "--point", "12.5,-3"}), &out), 0) << out;
  std::istringstream lines(out);
  std::string header, row;
  std::getline(lines, header);
  EXPECT_EQ(header, "x,y,source_x,source_y,height,displacement_x,displacement_y,normal_x,normal_y,normal_z");
  int rows = 0;
  while (std::getline(lines, row)) rows += !row.empty();
  EXPECT_EQ(rows, 2) << out;
}

// The preview goes beside the EXR, never over it: "x.exr" gives x.png, a name with no extension gets ".png"
// appended, and a name with another extension is refused (the file would be an EXR whatever it says).
// A file that cannot be written in full (a full disk) exits 5, as a file that cannot be opened does.
TEST(OceanCli, ThePreviewNeverReplacesTheTileAndAFullDiskExitsFive) {
  const std::string dir = test::temp_dir("ocean-cli-names");
  std::string out;
  EXPECT_EQ(test::run(cli_args({"tile", "--grid", "16", "-o", dir + "/t.png"}), &out), 2) << out;
  EXPECT_NE(out.find("t.png: the file is written as OpenEXR (its PNG preview beside it), so its name ends in .exr"),
            std::string::npos)
      << out;
  EXPECT_FALSE(std::filesystem::exists(dir + "/t.png"));
  ASSERT_EQ(test::run(cli_args({"tile", "--grid", "16", "-o", dir + "/t"}), &out), 0) << out;
  std::ifstream exr(dir + "/t", std::ios::binary);
  char magic[4] = {};
  exr.read(magic, 4);
  EXPECT_EQ(std::string(magic, 4), std::string("\x76\x2f\x31\x01", 4)) << "t holds the EXR";
  EXPECT_TRUE(std::filesystem::exists(dir + "/t.png"));
  if (std::filesystem::exists("/dev/full")) {
    EXPECT_EQ(test::run(cli_args({"tile", "--grid", "16", "--preview", "none", "-o", "/dev/full"}), &out), 5) << out;
    EXPECT_NE(out.find("cannot write /dev/full"), std::string::npos) << out;
  }
  // A preview that cannot be written takes its EXR with it: both files or neither.
  EXPECT_EQ(test::run(cli_args({"tile", "--grid", "16", "-o", dir + "/u.exr", "--preview", dir + "/no/u.png"}), &out),
            5)
      << out;
  EXPECT_FALSE(std::filesystem::exists(dir + "/u.exr"));
}

TEST(OceanCli, ReadableErrorsAndExitCodes) {
  std::string out;
  EXPECT_EQ(test::run(cli_args({"tile", "--wind-speed", "fast", "-o", "x.exr"}), &out), 2) << out;
  EXPECT_NE(out.find("--wind-speed fast: must be a finite number (m/s)"), std::string::npos) << out;
  EXPECT_EQ(test::run(cli_args({"tile", "--wind-speed", "0x10", "-o", "x.exr"}), &out), 2) << out;  // decimal only
  EXPECT_NE(out.find("--wind-speed 0x10: must be a finite number (m/s)"), std::string::npos) << out;
  EXPECT_EQ(test::run(cli_args({"tile", "--outputs", "height,", "-o", "x.exr"}), &out), 2) << out;
  EXPECT_NE(out.find("--outputs height,: an empty item in the list"), std::string::npos) << out;
  EXPECT_EQ(test::run(cli_args({"tile", "--grid", "8,8,8", "-o", "x.exr"}), &out), 2) << out;  // named whole
  EXPECT_NE(out.find("--grid 8,8,8: one value or two (A,B or AxB)"), std::string::npos) << out;
  EXPECT_EQ(test::run(cli_args({"tile", "--spectrum", "nope", "-o", "x.exr"}), &out), 2) << out;
  EXPECT_NE(out.find("must be one of"), std::string::npos) << out;
  EXPECT_EQ(test::run(cli_args({"sample", "--point", "1"}), &out), 2) << out;  // one number is no point
  EXPECT_NE(out.find("--point 1: must be X,Y (m)"), std::string::npos) << out;
  EXPECT_EQ(test::run(cli_args({"sample", "--point", "1,2,3"}), &out), 2) << out;  // named whole
  EXPECT_NE(out.find("--point 1,2,3: must be X,Y (m)"), std::string::npos) << out;
  EXPECT_EQ(test::run(cli_args({"sample", "--point", "1,north"}), &out), 2) << out;
  EXPECT_NE(out.find("--point 1,north: must be X,Y, two finite numbers (m)"), std::string::npos) << out;
  const std::string points = test::temp_dir("ocean-cli-points") + "/points.csv";
  std::ofstream(points) << "x,y\r\n1,2\r\n5\r\n";  // a line of one number, in a CRLF file
  EXPECT_EQ(test::run(cli_args({"sample", "--points-file", points}), &out), 2) << out;
  EXPECT_NE(out.find(":3 5: must be X,Y (m)"), std::string::npos) << out;
  // "Infinity" is a number, not a header (and no finite one); a header may follow comments and a byte order
  // mark.
  std::ofstream(points, std::ios::trunc) << "Infinity,2\n";
  EXPECT_EQ(test::run(cli_args({"sample", "--grid", "16", "--points-file", points}), &out), 2) << out;
  EXPECT_NE(out.find(":1 Infinity,2: must be X,Y, two finite numbers (m)"), std::string::npos) << out;
  std::ofstream(points, std::ios::trunc) << "\xEF\xBB\xBF# made by hand\nx,y\n1,2\n";
  EXPECT_EQ(test::run(cli_args({"sample", "--grid", "16", "--points-file", points}), &out), 0) << out;
  EXPECT_NE(out.find("\n1,2,"), std::string::npos) << out;
  EXPECT_EQ(test::run(cli_args({"sample", "--points-file", test::temp_dir("ocean-cli-folder")}), &out), 2) << out;
  EXPECT_NE(out.find("cannot read it"), std::string::npos) << out;
  EXPECT_EQ(test::run(cli_args({"stream", "--frames", "2", "-o", "d"}), &out), 2) << out;
  EXPECT_NE(out.find("--dt"), std::string::npos) << out;
  // A flag the verb would ignore, or one of squall's own given after the verb, is refused naming it.
  EXPECT_EQ(test::run(cli_args({"tile", "--frames", "3", "-o", "x.exr"}), &out), 2) << out;
  EXPECT_NE(out.find("--frames is not a flag of `squall ocean tile`"), std::string::npos) << out;
  EXPECT_EQ(test::run(cli_args({"sample", "--outputs", "height", "--point", "1,2"}), &out), 2) << out;
  EXPECT_NE(out.find("--outputs is not a flag of `squall ocean sample`"), std::string::npos) << out;
  EXPECT_EQ(test::run(cli_args({"stream", "--time", "5", "--dt", "1", "--frames", "2", "-o", "d"}), &out), 2) << out;
  EXPECT_NE(out.find("--time is not a flag of `squall ocean stream`"), std::string::npos) << out;
  EXPECT_EQ(test::run(cli_args({"tile", "--timeout", "5", "-o", "x.exr"}), &out), 2) << out;
  EXPECT_NE(out.find("--timeout is a flag of squall itself: give it before the verb"), std::string::npos) << out;
  // The server refuses: exit 4, with the field named; the folders made for a stream are removed again.
  std::string dir = test::temp_dir("ocean-cli-bad");
  EXPECT_EQ(test::run(cli_args({"tile", "--wind-speed", "-1", "-o", dir + "/x.exr"}), &out), 4) << out;
  EXPECT_NE(out.find("INVALID_ARGUMENT"), std::string::npos) << out;
  EXPECT_NE(out.find("tile.layers[0].wind_speed = -1"), std::string::npos) << out;
  EXPECT_EQ(test::run(cli_args({"stream", "--wind-speed", "-1", "--dt", "1", "--frames", "2", "-o",
                                dir + "/frames/of/today"}),
                      &out),
            4)
      << out;
  EXPECT_FALSE(std::filesystem::exists(dir + "/frames")) << out;  // nor the parents made for it
  EXPECT_EQ(
      test::run(cli_args({"stream", "--wind-speed", "-1", "--dt", "1", "--frames", "2", "-o", dir + "/up/../frames"}),
                &out),
      4)
      << out;
  EXPECT_FALSE(std::filesystem::exists(dir + "/up")) << out;
  // A preview that would replace the image it previews.
  EXPECT_EQ(test::run(cli_args({"tile", "-o", dir + "/t.exr", "--preview", dir + "/./t.exr"}), &out), 2) << out;
  EXPECT_NE(out.find("is the file -o names"), std::string::npos) << out;
}

// A stream's deadline is --timeout for each frame, not for the whole stream: 150 frames, each computed by
// squalld and written as an EXR by the client, take longer than one 0.1 s deadline on any machine.
TEST(OceanCli, AStreamHasTheTimeoutForEachFrame) {
  const std::string dir = test::temp_dir("ocean-cli-stream-deadline");
  std::vector<std::string> args = {
      kSquall, "--address", daemon().address(), "--timeout", "0.1", "ocean", "stream", "--grid", "128",
      "--dt",  "0.1",       "--frames",         "150",       "-o",  dir};
  std::string out;
  ASSERT_EQ(test::run(args, &out, 120), 0) << out;
  EXPECT_TRUE(std::filesystem::exists(dir + "/frame_00149.exr")) << out;
}

}  // namespace
}  // namespace squall
