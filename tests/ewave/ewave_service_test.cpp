// squall.v1.EWave for real: squalld started on free localhost ports, driven through the generated stub and
// the `squall ewave wake` CLI. The daemon's frames are compared with the engine run in this process on
// the same device and FFT backend, so the proto <-> engine translation is checked value by value.
#include <gtest/gtest.h>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfStringAttribute.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <thread>

#include "client/client.h"
#include "client/image_io.h"
#include "ewave/ewave_config.h"
#include "ewave/ewave_request.h"
#include "ewave/ewave_session.h"
#include "ewave_support.h"
#include "common/field_codec.h"
#include "common/float16.h"
#include "squall/v1/ewave.grpc.pb.h"
#include "squall/v1/ocean.grpc.pb.h"
#include "ewave/ewave_service.h"
#include "ocean/ocean_engine.h"
#include "rpc/metadata.h"
#include "support/daemon.h"
#include "support/expect_error.h"
#include "support/in_process.h"
#include "support/test_runtime.h"

namespace squall {
namespace {

namespace v1 = squall::v1;
const std::string kSquall = test::squall_path();

// A squalld with its EWave stub.
class Daemon : public test::Daemon {
 public:
  explicit Daemon(const std::vector<std::string>& flags)
      : test::Daemon(flags), stub_(v1::EWave::NewStub(client::Client({address(), 5, ""}).channel())) {}
  v1::EWave::Stub& stub() { return *stub_; }

 private:
  std::unique_ptr<v1::EWave::Stub> stub_;
};

// Both pinned to VkFFT so that a state moves between them bit-identically.
Daemon& first() {
  static Daemon d({"--fft", "vkfft", "--max-sessions", "3", "--max-streams", "2"});
  return d;
}
Daemon& second() {
  static Daemon d({"--fft", "vkfft", "--session-ttl", "1"});
  return d;
}

std::unique_ptr<grpc::ClientContext> context(double seconds = 60) {
  auto c = std::make_unique<grpc::ClientContext>();
  c->set_deadline(std::chrono::system_clock::now() + std::chrono::milliseconds(int64_t(seconds * 1000)));
  return c;
}

v1::Field field(uint32_t nx, uint32_t ny, const std::vector<float>& values) {
  v1::Field f;
  f.set_nx(nx), f.set_ny(ny), f.set_dtype(v1::DTYPE_FLOAT32);
  f.set_data(reinterpret_cast<const char*>(values.data()), values.size() * 4);
  return f;
}

std::vector<float> values(const v1::Field& f) { return squall::field::decode(f, "fields." + f.name()); }

// A 64 x 48 deep-water session at 1 cm with a Gaussian hump (engine and proto forms of one config).
ewave::EWaveConfig engine_config() {
  ewave::EWaveConfig c = ewave::test::plain_config(64, 48);
  c.trim = true;
  c.source_scale = 0.5;
  c.initial_height = ewave::test::field(c, [](double x, double y) {
    return 0.01 * std::exp(-(std::pow(x - 0.3, 2) + std::pow(y - 0.24, 2)) / (2 * 0.03 * 0.03));
  });
  return c;
}

v1::EWaveConfig proto_config(const ewave::EWaveConfig& c) {
  v1::EWaveConfig p;
  p.set_nx(uint32_t(c.nx)), p.set_ny(uint32_t(c.ny)), p.set_dx(c.dx), p.set_dy(c.dy);
  p.set_trim(c.trim);
  p.set_source_scale(c.source_scale);
  if (!c.initial_height.empty()) *p.mutable_initial_height() = field(uint32_t(c.nx), uint32_t(c.ny), c.initial_height);
  return p;
}

// A session on a daemon, closed (best effort) when it goes out of scope.
class Session {
 public:
  Session(v1::EWave::Stub& stub, const v1::EWaveConfig& config) : stub_(stub) {
    v1::EWaveCreateSessionRequest request;
    *request.mutable_config() = config;
    v1::EWaveSessionResponse reply;
    status_ = stub.CreateSession(context().get(), request, &reply);
    id_ = reply.session_id();
  }
  Session(v1::EWave::Stub& stub, const std::string& id) : stub_(stub), id_(id) {}
  ~Session() { close(); }
  grpc::Status close() {
    v1::EWaveSessionRequest request;
    request.set_session_id(id_);
    v1::EWaveCloseResponse reply;
    return stub_.CloseSession(context().get(), request, &reply);
  }
  grpc::Status step(const v1::EWaveInputs& inputs, v1::EWaveFrame* frame, const ewave::StepGuard& guard = {}) {
    v1::EWaveStepRequest request;
    request.set_session_id(id_);
    *request.mutable_inputs() = inputs;
    request.set_retry_key(guard.retry_key);
    if (guard.after_step) request.set_after_step(*guard.after_step);
    return stub_.Step(context().get(), request, frame);
  }
  const std::string& id() const { return id_; }
  const grpc::Status& status() const { return status_; }

 private:
  v1::EWave::Stub& stub_;
  std::string id_;
  grpc::Status status_;
};

v1::EWaveInputs plain_inputs(double dt) {
  v1::EWaveInputs in;
  in.set_dt(dt);
  in.add_outputs(v1::EWAVE_OUTPUT_HEIGHT);
  in.add_outputs(v1::EWAVE_OUTPUT_PHI);
  return in;
}

TEST(EWaveService, CreateStepCloseMatchesTheEngineInProcess) {
  ewave::EWaveConfig c = engine_config();
  Session s(first().stub(), proto_config(c));
  ASSERT_TRUE(s.status().ok()) << s.status().error_message();
  EXPECT_EQ(s.id().size(), 32u);
  EXPECT_EQ(s.id().find_first_not_of("0123456789abcdef"), std::string::npos) << s.id();

  // The same steps in this process: an ellipse moving along x (shape translation), a uniform drift.
  ewave::EWaveSession local(test::runtime(), test::fft(), c);
  v1::EWaveFrame frame;
  ewave::Frame expected;
  for (int n = 0; n < 3; ++n) {
    v1::EWaveInputs in = plain_inputs(0.01);
    in.add_outputs(v1::EWAVE_OUTPUT_NORMAL_Z);
    in.set_drift_x(0.25);
    auto* e = in.add_shapes()->mutable_ellipse();
    e->set_center_x(0.2 + 0.01 * n), e->set_center_y(0.2), e->set_semi_axis_a(0.06), e->set_semi_axis_b(0.02);
    e->set_heading(0.3);
    ASSERT_TRUE(s.step(in, &frame).ok());
    ewave::StepInputs li = ewave::test::plain_step(0.01);
    li.outputs.normals = true;
    li.drift_x = 0.25;
    li.shapes = {ewave::Shape{ewave::ShapeKind::Ellipse, 0.2 + 0.01 * n, 0.2, 0.06, 0.02, 0.3, {}}};
    expected = local.step(li);
  }
  EXPECT_EQ(frame.session_id(), s.id());
  EXPECT_EQ(frame.step(), 3u);
  EXPECT_NEAR(frame.time().seconds(), 0.03, 1e-15);
  ASSERT_EQ(frame.fields_size(), 3);
  EXPECT_EQ(frame.fields(0).name(), "height");
  EXPECT_EQ(frame.fields(1).name(), "phi");
  EXPECT_EQ(frame.fields(1).unit(), "m^2/s");
  EXPECT_EQ(frame.fields(2).name(), "normal_z");
  EXPECT_DOUBLE_EQ(frame.fields(0).origin().x(), 0.005);
  EXPECT_DOUBLE_EQ(frame.fields(0).spacing().y(), 0.01);
  std::vector<float> normal_z(expected.normals.size() / 3);
  for (size_t i = 0; i < normal_z.size(); ++i) normal_z[i] = expected.normals[3 * i + 2];
  // Same device, same kernels, same FFT backend: the daemon's numbers are the engine's, bit for bit.
  EXPECT_EQ(values(frame.fields(0)), expected.height);
  EXPECT_EQ(values(frame.fields(1)), expected.phi);
  EXPECT_EQ(values(frame.fields(2)), normal_z);
  EXPECT_GT(ewave::test::max_abs(expected.height), 1e-4) << "the hump and the source must show";
  EXPECT_TRUE(s.close().ok());
}

// A deep-water Pierson-Moskowitz layer of 100 m x 100 m on an n x n grid.
v1::LayerSpec sea_layer(uint32_t n) {
  v1::LayerSpec layer;
  layer.set_extent_x(100), layer.set_extent_y(100), layer.set_nx(n), layer.set_ny(n);
  layer.set_spectrum(v1::SPECTRUM_MODEL_PIERSON_MOSKOWITZ);
  layer.set_spreading(v1::SPREADING_MODEL_MITSUYASU);
  layer.set_dispersion(v1::DISPERSION_MODEL_DEEP);
  layer.set_wind_speed(5);
  return layer;
}

// The request translator checks a step's ambient ocean against the daemon's --max-grid-cells (the gate it
// is given), as it does the config's ocean specs.
TEST(EWaveService, AStepsAmbientOceanIsCheckedAgainstTheDaemonsGridLimit) {
  const ewave::EWaveConfig c = engine_config();
  v1::EWaveInputs in = plain_inputs(0.01);
  *in.mutable_ambient_ocean()->add_layers() = sea_layer(128);
  const LimitGate defaults{Limits{}};
  EXPECT_TRUE(ewave::rpc::inputs(in, c, defaults).ambient_ocean.has_value());
  Limits small;
  small.max_grid_cells = uint64_t(c.cells());
  test::expect_error(Code::ResourceExhausted, "inputs.ambient_ocean.layers[0]",
                     [&] { ewave::rpc::inputs(in, c, LimitGate{small}); });
}

// A step's ambient ocean counts in the memory budget: its 2048^2 layer's spectrum (6 floats a mode, 101 MB)
// and fields, refused under a 64 MiB budget before anything is built, the session as it was; the same step
// with a 64^2 layer runs, and so does one with no obstruction, where the ocean is not evaluated. A session's
// initial ocean counts alike.
TEST(EWaveService, AnAmbientOrInitialOceanCountsInTheMemoryBudget) {
  Daemon d({"--memory-budget", std::to_string(64 << 20)});
  Session s(d.stub(), proto_config(engine_config()));
  ASSERT_TRUE(s.status().ok()) << s.status().error_message();
  v1::EWaveInputs in = plain_inputs(0.01);
  *in.mutable_obstruction() = field(64, 48, std::vector<float>(64 * 48, 0.5f));  // the ocean is evaluated
  v1::LayerSpec* layer = in.mutable_ambient_ocean()->add_layers();
  *layer = sea_layer(2048);
  v1::EWaveFrame frame;
  v1::EWaveInputs open_water = in;  // no obstruction: h_A (1 - O) = 0, the ocean is neither built nor reserved
  open_water.clear_obstruction();
  const grpc::Status unobstructed = s.step(open_water, &frame);
  EXPECT_TRUE(unobstructed.ok()) << unobstructed.error_message();
  const grpc::Status refused = s.step(in, &frame);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << refused.error_message();
  EXPECT_NE(refused.error_message().find("Step's frame and inputs.ambient_ocean"), std::string::npos)
      << refused.error_message();
  layer->set_nx(64), layer->set_ny(64);
  const grpc::Status ran = s.step(in, &frame);
  EXPECT_TRUE(ran.ok()) << ran.error_message();
  EXPECT_EQ(frame.step(), 2u) << "the refused step made none";
  // The same for a session's initial ocean, evaluated as the session is made.
  v1::EWaveConfig from_the_sea = proto_config(ewave::test::plain_config(64, 48));
  *from_the_sea.mutable_initial_ocean() = in.ambient_ocean();
  from_the_sea.mutable_initial_ocean()->mutable_layers(0)->set_nx(2048);
  from_the_sea.mutable_initial_ocean()->mutable_layers(0)->set_ny(2048);
  const Session big(d.stub(), from_the_sea);
  EXPECT_EQ(big.status().error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << big.status().error_message();
  EXPECT_NE(big.status().error_message().find("CreateSession's config.initial_ocean"), std::string::npos)
      << big.status().error_message();
  from_the_sea.mutable_initial_ocean()->mutable_layers(0)->set_nx(64);
  from_the_sea.mutable_initial_ocean()->mutable_layers(0)->set_ny(64);
  const Session small(d.stub(), from_the_sea);
  EXPECT_TRUE(small.status().ok()) << small.status().error_message();
}

// A step whose ambient ocean's spectrum was kept, and then taken back by the cache to make room for the step
// itself, reserves the spectrum it builds again: under a budget that holds a first step (its spectrum built
// and kept) and half of what seven more output planes add, such a second step is refused naming the rebuild.
TEST(EWaveService, AStepWhoseKeptSpectrumIsTakenBackReservesItsRebuild) {
  const ewave::EWaveConfig c = ewave::test::plain_config(256, 256);
  v1::EWaveInputs height;
  height.set_dt(0.01);
  height.add_outputs(v1::EWAVE_OUTPUT_HEIGHT);
  *height.mutable_obstruction() = field(256, 256, std::vector<float>(256 * 256, 0.5f));  // the ocean is evaluated
  *height.mutable_ambient_ocean()->add_layers() = sea_layer(1024);
  v1::EWaveInputs all = height;
  for (int o = v1::EWAVE_OUTPUT_DISPLACEMENT_X; o <= v1::EWAVE_OUTPUT_PHI; ++o) all.add_outputs(v1::EWaveOutput(o));
  const LimitGate unlimited{Limits{}};
  const ewave::StepInputs in = ewave::rpc::inputs(height, c, unlimited);
  auto frame = [&](const v1::EWaveInputs& step) {
    return ewave::rpc::frame_host_bytes(c, ewave::rpc::inputs(step, c, unlimited).outputs) +
           ewave::rpc::frame_bytes(c, size_t(step.outputs_size()), v1::DTYPE_FLOAT32);
  };
  const uint64_t added = frame(all) - frame(height),
                 fields = ocean::surface_device_bytes(ewave::ocean_on_grid(*in.ambient_ocean, c));
  uint64_t session = 0, spectrum = 0;  // what a live session holds of the budget, and the kept spectrum
  {
    test::InProcess<rpc::EWaveService> measured;
    auto stub = v1::EWave::NewStub(measured.channel());
    Session s(*stub, proto_config(c));
    ASSERT_TRUE(s.status().ok()) << s.status().error_message();
    session = measured.serving().gate().memory_bytes();
    v1::EWaveFrame f;
    ASSERT_TRUE(s.step(height, &f).ok());
    spectrum = measured.serving().gate().cached_memory_bytes();
    ASSERT_GE(spectrum, 1024ull * 1024 * 6 * sizeof(float));  // at least six floats a mode
  }
  Limits limits;
  limits.memory_budget = session + frame(height) + fields + spectrum + added / 2;
  test::InProcess<rpc::EWaveService> server(limits);
  auto stub = v1::EWave::NewStub(server.channel());
  Session s(*stub, proto_config(c));
  ASSERT_TRUE(s.status().ok()) << s.status().error_message();
  v1::EWaveFrame f;
  const grpc::Status first = s.step(height, &f);
  ASSERT_TRUE(first.ok()) << first.error_message();
  ASSERT_EQ(server.serving().gate().cached_memory_bytes(), spectrum);
  const grpc::Status refused = s.step(all, &f);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << refused.error_message();
  EXPECT_NE(refused.error_message().find("inputs.ambient_ocean's spectra, built again"), std::string::npos)
      << refused.error_message();
}

// A session whose initial ocean's spectrum is kept holds it while it reserves its own bytes: under a budget
// that holds a first such session, the spectrum it kept, the ocean's fields and half a session more, a
// second is refused naming the session, and the spectrum stays kept (without the hold the cache took it
// back to make room, the rebuild was refused, and neither was kept); with the spectrum's bytes more it is
// made.
TEST(EWaveService, ASessionHoldsItsInitialOceansKeptSpectrumWhileItReservesItsBytes) {
  const ewave::EWaveConfig c = ewave::test::plain_config(256, 256);
  v1::EWaveConfig from_the_sea = proto_config(c);
  *from_the_sea.mutable_initial_ocean()->add_layers() = sea_layer(1024);
  const ewave::EWaveConfig translated = ewave::rpc::config(from_the_sea, LimitGate{Limits{}});
  const uint64_t fields = ocean::surface_device_bytes(ewave::ocean_on_grid(*translated.initial_ocean, c));
  uint64_t session = 0, spectrum = 0;  // what a live session holds of the budget, and the kept spectrum
  {
    test::InProcess<rpc::EWaveService> measured;
    auto stub = v1::EWave::NewStub(measured.channel());
    Session s(*stub, from_the_sea);
    ASSERT_TRUE(s.status().ok()) << s.status().error_message();
    spectrum = measured.serving().gate().cached_memory_bytes();
    session = measured.serving().gate().memory_bytes() - spectrum;
    ASSERT_GE(spectrum, 1024ull * 1024 * 6 * sizeof(float));  // at least six floats a mode
    ASSERT_GE(spectrum, session / 2) << "the session's reservation would not take the spectrum back";
  }
  for (const auto& [more, code] :
       {std::pair{uint64_t(0), grpc::StatusCode::RESOURCE_EXHAUSTED}, std::pair{spectrum, grpc::StatusCode::OK}}) {
    Limits limits;
    limits.memory_budget = session + spectrum + fields + session / 2 + more;
    test::InProcess<rpc::EWaveService> server(limits);
    auto stub = v1::EWave::NewStub(server.channel());
    const Session first(*stub, from_the_sea);
    ASSERT_TRUE(first.status().ok()) << first.status().error_message();
    ASSERT_EQ(server.serving().gate().cached_memory_bytes(), spectrum);
    const Session second(*stub, from_the_sea);
    EXPECT_EQ(second.status().error_code(), code) << second.status().error_message();
    if (code != grpc::StatusCode::OK) {
      EXPECT_NE(second.status().error_message().find("keeping this eWave session"), std::string::npos)
          << second.status().error_message();
    }
    EXPECT_EQ(server.serving().gate().cached_memory_bytes(), spectrum);
  }
}

// GetState reserves the state it reads (a 512^2 double session's 4 MiB of fields) before reading it: refused
// under a budget that holds the session and 2 MiB more, served under one with 8 MiB more.
TEST(EWaveService, GetStateReservesItsStateBeforeReadingIt) {
  ewave::EWaveConfig c = ewave::test::plain_config(512, 512);
  c.double_precision = true;
  v1::EWaveConfig config = proto_config(c);
  config.set_double_precision(true);
  for (const auto& [more, code] :
       {std::pair{2 << 20, grpc::StatusCode::RESOURCE_EXHAUSTED}, std::pair{8 << 20, grpc::StatusCode::OK}}) {
    Daemon d({"--memory-budget", std::to_string(ewave::session_bytes(c) + more)});
    Session s(d.stub(), config);
    ASSERT_TRUE(s.status().ok()) << s.status().error_message();
    v1::EWaveSessionRequest get;
    get.set_session_id(s.id());
    v1::EWaveStateResponse state;
    const grpc::Status status = d.stub().GetState(context().get(), get, &state);
    EXPECT_EQ(status.error_code(), code) << more << ": " << status.error_message();
    if (status.ok()) {
      EXPECT_GT(state.state().size(), 4u << 20);
    } else {
      EXPECT_NE(status.error_message().find("GetState's state"), std::string::npos) << status.error_message();
    }
  }
}

// A session created from an ocean spec over gRPC (config.initial_ocean at config.start_time = t0) continues
// the ocean: its first frame (t0 + dt) equals GetTile's height of the same spec at t0 + dt on the session
// grid. Float round-off only (the engine test ewave_ocean_test budgets it at a few 1e-6): asserted < 1e-4.
TEST(EWaveService, SessionFromAnOceanSpecContinuesGetTile) {
  const uint32_t n = 64;
  const double spacing = 1.0, t0 = 7.5, dt = 0.1;
  v1::TileSpec tile;
  v1::LayerSpec* layer = tile.add_layers();
  layer->set_extent_x(n * spacing), layer->set_extent_y(n * spacing), layer->set_nx(n), layer->set_ny(n);
  layer->set_spectrum(v1::SPECTRUM_MODEL_PIERSON_MOSKOWITZ);
  layer->set_spreading(v1::SPREADING_MODEL_MITSUYASU);
  layer->set_dispersion(v1::DISPERSION_MODEL_DEEP);
  layer->set_wind_speed(5), layer->set_wind_direction(0.4), layer->set_seed(11);
  v1::EWaveConfig config;
  config.set_nx(n), config.set_ny(n), config.set_dx(spacing), config.set_dy(spacing);
  config.set_trim(false);
  config.mutable_start_time()->set_seconds(t0);
  *config.mutable_initial_ocean() = tile;
  Session s(first().stub(), config);
  ASSERT_TRUE(s.status().ok()) << s.status().error_message();
  v1::EWaveInputs in;
  in.set_dt(dt);
  v1::EWaveFrame frame;
  grpc::Status status = s.step(in, &frame);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_NEAR(frame.time().seconds(), t0 + dt, 1e-12);

  auto ocean = v1::Ocean::NewStub(client::Client({first().address(), 5, ""}).channel());
  v1::GetTileRequest request;
  *request.mutable_tile() = tile;
  request.mutable_time()->set_seconds(t0 + dt);
  request.add_outputs(v1::TILE_OUTPUT_HEIGHT);
  v1::GetTileResponse reply;
  status = ocean->GetTile(context().get(), request, &reply);
  ASSERT_TRUE(status.ok()) << status.error_message();
  std::vector<float> got = values(frame.fields(0)), want = values(reply.fields(0));
  ASSERT_EQ(got.size(), want.size());
  double error = ewave::test::rms_difference(got, want) / ewave::test::rms(want);
  std::printf("[ewave service] first frame vs GetTile(t0 + dt): relative rms difference %.3g\n", error);
  EXPECT_LT(error, 1e-4);

  // A bad layer in the ocean spec is INVALID_ARGUMENT naming the field.
  config.mutable_initial_ocean()->mutable_layers(0)->set_wind_speed(NAN);
  Session bad(first().stub(), config);
  EXPECT_EQ(bad.status().error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(bad.status().error_message().find("config.initial_ocean.layers[0].wind_speed"), std::string::npos)
      << bad.status().error_message();
}

TEST(EWaveService, Float16FramesRoundToHalfPrecision) {
  Session s(first().stub(), proto_config(engine_config()));
  v1::EWaveInputs in = plain_inputs(0.02);
  v1::EWaveFrame f32, f16;
  ASSERT_TRUE(s.step(in, &f32).ok());
  Session t(first().stub(), proto_config(engine_config()));
  in.set_dtype(v1::DTYPE_FLOAT16);
  ASSERT_TRUE(t.step(in, &f16).ok());
  ASSERT_EQ(f16.fields(0).data().size(), 64u * 48u * 2u);
  std::vector<float> a = values(f32.fields(0)), b = values(f16.fields(0));
  for (size_t i = 0; i < a.size(); ++i) ASSERT_EQ(b[i], f16::to_float(f16::from_float(a[i]))) << i;
}

TEST(EWaveService, RunStreamReturnsFramesInOrderWithStepAndTime) {
  Session s(first().stub(), proto_config(engine_config()));
  auto ctx = context();
  auto call = first().stub().Run(ctx.get());
  const double dts[] = {0.01, 0.02, 0.005, 0.01, 0.03};
  for (double dt : dts) {
    v1::EWaveStepRequest r;
    r.set_session_id(s.id());
    *r.mutable_inputs() = plain_inputs(dt);
    ASSERT_TRUE(call->Write(r));
  }
  call->WritesDone();
  v1::EWaveFrame f;
  double t = 0;
  uint64_t n = 0;
  while (call->Read(&f)) {
    t += dts[n++];
    EXPECT_EQ(f.step(), n);
    EXPECT_DOUBLE_EQ(f.time().seconds(), t);
    EXPECT_EQ(f.session_id(), s.id());
  }
  EXPECT_EQ(n, 5u);
  EXPECT_TRUE(call->Finish().ok());
}

TEST(EWaveService, RunEndsWithTheStatusOfABadMessage) {
  Session s(first().stub(), proto_config(engine_config()));
  auto ctx = context();
  auto call = first().stub().Run(ctx.get());
  v1::EWaveStepRequest r;
  r.set_session_id(s.id());
  *r.mutable_inputs() = plain_inputs(0.01);
  ASSERT_TRUE(call->Write(r));
  r.mutable_inputs()->set_dt(0);
  call->Write(r);
  call->WritesDone();
  v1::EWaveFrame f;
  int frames = 0;
  while (call->Read(&f)) ++frames;
  grpc::Status status = call->Finish();
  EXPECT_EQ(frames, 1);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("Run message 1: inputs.dt = 0"), std::string::npos) << status.error_message();
}

// --max-sessions-per-client: the sessions one client creates (CreateSession or Restore) count against its
// share for their lives, so that one client cannot take every --max-sessions slot; closing one frees it.
TEST(EWaveService, AClientsSessionsCountAgainstItsShare) {
  Limits limits;
  limits.max_sessions_per_client = 2;
  test::InProcess<rpc::EWaveService> server(limits);
  auto stub = v1::EWave::NewStub(server.channel());
  Session a(*stub, proto_config(engine_config()));
  auto b = std::make_unique<Session>(*stub, proto_config(engine_config()));
  ASSERT_TRUE(a.status().ok() && b->status().ok()) << a.status().error_message() << b->status().error_message();
  Session refused(*stub, proto_config(engine_config()));
  EXPECT_EQ(refused.status().error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_NE(refused.status().error_message().find("2 already live, the limit is --max-sessions-per-client = 2"),
            std::string::npos)
      << refused.status().error_message();
  EXPECT_TRUE(refused.id().empty());  // no session was made
  v1::EWaveSessionRequest get;
  get.set_session_id(a.id());
  v1::EWaveStateResponse state;
  ASSERT_TRUE(stub->GetState(context().get(), get, &state).ok());
  v1::EWaveRestoreRequest restore;
  restore.set_state(state.state());
  v1::EWaveSessionResponse restored;
  const grpc::Status restore_refused = stub->Restore(context().get(), restore, &restored);
  EXPECT_EQ(restore_refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << restore_refused.error_message();
  EXPECT_NE(restore_refused.error_message().find("--max-sessions-per-client"), std::string::npos)
      << restore_refused.error_message();
  b.reset();  // closed: its slot comes back
  const grpc::Status status = stub->Restore(context().get(), restore, &restored);
  ASSERT_TRUE(status.ok()) << status.error_message();
  Session c(*stub, restored.session_id());
  v1::EWaveFrame frame;
  const grpc::Status stepped = c.step(plain_inputs(0.01), &frame);
  ASSERT_TRUE(stepped.ok()) << stepped.error_message();
  EXPECT_EQ(frame.step(), 1u);                         // the restored session runs on from a's state
  Session full(*stub, proto_config(engine_config()));  // and holds the slot b gave back
  EXPECT_EQ(full.status().error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << full.status().error_message();
}

TEST(EWaveService, StateRestoredOnAnotherDaemonContinuesBitIdentically) {
  Session a(first().stub(), proto_config(engine_config()));
  v1::EWaveFrame f;
  for (int n = 0; n < 3; ++n) ASSERT_TRUE(a.step(plain_inputs(0.01), &f).ok());
  v1::EWaveSessionRequest get;
  get.set_session_id(a.id());
  v1::EWaveStateResponse state;
  ASSERT_TRUE(first().stub().GetState(context().get(), get, &state).ok());
  EXPECT_GT(state.state().size(), 2u * 64 * 48 * 4);

  v1::EWaveRestoreRequest restore;
  restore.set_state(state.state());
  v1::EWaveSessionResponse restored;
  grpc::Status status = second().stub().Restore(context().get(), restore, &restored);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_NE(restored.session_id(), a.id());
  EXPECT_EQ(restored.step(), 3u);  // the steps the saved session had made
  EXPECT_EQ(restored.config().nx(), 64u);
  EXPECT_DOUBLE_EQ(restored.config().source_scale(), 0.5);
  Session b(second().stub(), restored.session_id());

  v1::EWaveFrame fa, fb;
  for (int n = 0; n < 4; ++n) {
    ASSERT_TRUE(a.step(plain_inputs(0.015), &fa).ok());
    ASSERT_TRUE(b.step(plain_inputs(0.015), &fb).ok());
  }
  EXPECT_EQ(fa.step(), 7u);
  EXPECT_EQ(fb.step(), 7u);
  EXPECT_EQ(fa.time().seconds(), fb.time().seconds());
  EXPECT_EQ(fa.fields(0).data(), fb.fields(0).data()) << "height differs after restore";
  EXPECT_EQ(fa.fields(1).data(), fb.fields(1).data()) << "phi differs after restore";
  EXPECT_GT(ewave::test::max_abs(values(fa.fields(0))), 1e-4);
}

// A step sent twice with one retry key is made once: the second answer is the first frame again. A count
// the session is not at is ABORTED; a key past 64 bytes is refused by name.
TEST(EWaveService, AStepRetriedWithItsKeyIsMadeOnce) {
  Session a(first().stub(), proto_config(engine_config()));
  v1::EWaveFrame made, again;
  ASSERT_TRUE(a.step(plain_inputs(0.01), &made, {"step 1", std::nullopt}).ok());
  ASSERT_TRUE(a.step(plain_inputs(0.01), &again, {"step 1", std::nullopt}).ok());
  EXPECT_EQ(made.SerializeAsString(), again.SerializeAsString());
  const grpc::Status stale = a.step(plain_inputs(0.01), &again, {"step 2", 4});
  EXPECT_EQ(stale.error_code(), grpc::StatusCode::ABORTED);
  EXPECT_NE(stale.error_message().find("after_step = 4, but the session has made 1 steps"), std::string::npos)
      << stale.error_message();
  const grpc::Status long_key = a.step(plain_inputs(0.01), &again, {std::string(65, 'k'), std::nullopt});
  EXPECT_EQ(long_key.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(long_key.error_message().find("retry_key has 65 bytes"), std::string::npos) << long_key.error_message();
  ASSERT_TRUE(a.step(plain_inputs(0.01), &made, {"step 2", 1}).ok());
  EXPECT_EQ(made.step(), 2u);
}

TEST(EWaveService, ClosedUnknownAndEmptyIdsAreRefused) {
  auto s = std::make_unique<Session>(first().stub(), proto_config(engine_config()));
  const std::string id = s->id();
  v1::EWaveFrame f;
  ASSERT_TRUE(s->step(plain_inputs(0.01), &f).ok());
  ASSERT_TRUE(s->close().ok());
  grpc::Status status = s->step(plain_inputs(0.01), &f);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_NE(status.error_message().find("session_id"), std::string::npos) << status.error_message();
  v1::EWaveSessionRequest get;
  get.set_session_id(id);
  v1::EWaveStateResponse state;
  EXPECT_EQ(first().stub().GetState(context().get(), get, &state).error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(s->close().error_code(), grpc::StatusCode::NOT_FOUND);
  // A well-formed id nobody was given, and the other daemon's view of a live id.
  Session other(first().stub(), proto_config(engine_config()));
  Session random(first().stub(), std::string("0123456789abcdef0123456789abcdef"));
  EXPECT_EQ(random.step(plain_inputs(0.01), &f).error_code(), grpc::StatusCode::NOT_FOUND);
  Session elsewhere(second().stub(), other.id());
  EXPECT_EQ(elsewhere.step(plain_inputs(0.01), &f).error_code(), grpc::StatusCode::NOT_FOUND);
  Session empty(first().stub(), std::string());
  status = empty.step(plain_inputs(0.01), &f);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("session_id is empty"), std::string::npos) << status.error_message();
}

void expect_invalid(Session& s, const v1::EWaveInputs& in, const std::string& names) {
  v1::EWaveFrame f;
  grpc::Status status = s.step(in, &f);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << names;
  EXPECT_NE(status.error_message().find(names), std::string::npos) << status.error_message();
}

TEST(EWaveService, BadInputsAreInvalidArgumentNamingTheFieldAndTheDaemonServesOn) {
  Session s(first().stub(), proto_config(engine_config()));
  std::vector<float> ones(64 * 48, 1.0f);
  v1::EWaveInputs in = plain_inputs(0.01);
  *in.mutable_obstruction() = field(48, 64, ones);  // transposed
  expect_invalid(s, in, "inputs.obstruction.nx = 48, want the session's nx = 64");
  *in.mutable_obstruction() = field(64, 48, std::vector<float>(10, 1.0f));
  expect_invalid(s, in, "inputs.obstruction.data has 40 bytes");
  in.clear_obstruction();
  std::vector<float> source(64 * 48, 0.0f);
  source[77] = NAN;
  *in.mutable_source_height() = field(64, 48, source);
  expect_invalid(s, in, "inputs.source_height[77] = nan");
  in.clear_source_height();
  ones[5] = 1.5f;
  *in.mutable_obstruction() = field(64, 48, ones);
  expect_invalid(s, in, "inputs.obstruction[5] = 1.5");
  in.clear_obstruction();
  for (double dt : {0.0, -0.01, double(NAN)}) {
    in.set_dt(dt);
    expect_invalid(s, in, "inputs.dt");
  }
  in.set_dt(0.01);
  in.add_shapes()->mutable_circle()->set_radius(-1);
  expect_invalid(s, in, "inputs.shapes[0].circle.radius = -1");
  in.clear_shapes();
  in.add_outputs(v1::EWAVE_OUTPUT_HEIGHT);
  expect_invalid(s, in, "inputs.outputs[2] = EWAVE_OUTPUT_HEIGHT is listed twice");

  v1::EWaveConfig bad = proto_config(engine_config());
  bad.set_dx(NAN);
  Session refused(first().stub(), bad);
  EXPECT_EQ(refused.status().error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(refused.status().error_message().find("config.dx = nan"), std::string::npos);
  bad = proto_config(engine_config());
  bad.set_ny(47);  // the initial height is 64 x 48
  Session misfit(first().stub(), bad);
  EXPECT_NE(misfit.status().error_message().find("config.initial_height.ny = 48, want the session's ny = 47"),
            std::string::npos)
      << misfit.status().error_message();

  // The rejected steps left the session where it was; the daemon still serves it.
  v1::EWaveFrame f;
  ASSERT_TRUE(s.step(plain_inputs(0.01), &f).ok());
  EXPECT_EQ(f.step(), 1u);
}

TEST(EWaveService, SessionsBeyondMaxSessionsAreResourceExhausted) {
  std::vector<std::unique_ptr<Session>> live;
  for (int n = 0; n < 3; ++n) {
    live.push_back(std::make_unique<Session>(first().stub(), proto_config(engine_config())));
    ASSERT_TRUE(live.back()->status().ok()) << live.back()->status().error_message();
  }
  Session fourth(first().stub(), proto_config(engine_config()));
  EXPECT_EQ(fourth.status().error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_NE(fourth.status().error_message().find("--max-sessions"), std::string::npos)
      << fourth.status().error_message();
  ASSERT_TRUE(live.back()->close().ok());
  Session again(first().stub(), proto_config(engine_config()));
  EXPECT_TRUE(again.status().ok()) << again.status().error_message();
}

TEST(EWaveService, IdleSessionsAreEvictedAfterTheTtl) {
  test::InProcess<rpc::EWaveService> server(Limits{}, std::chrono::seconds(1));
  auto stub = v1::EWave::NewStub(server.channel());
  Session s(*stub, proto_config(engine_config()));
  ASSERT_TRUE(s.status().ok()) << s.status().error_message();
  v1::EWaveFrame f;
  ASSERT_TRUE(s.step(plain_inputs(0.01), &f).ok());
  server.advance(std::chrono::milliseconds(600));
  ASSERT_TRUE(s.step(plain_inputs(0.01), &f).ok()) << "a used session stays";
  server.advance(std::chrono::milliseconds(1001));
  grpc::Status status = s.step(plain_inputs(0.01), &f);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::NOT_FOUND) << status.error_message();
}

TEST(EWaveService, CreatedSessionsAreAnnouncedForSessionAffineProxies) {
  test::InProcess<rpc::EWaveService> server;
  auto stub = v1::EWave::NewStub(server.channel());
  v1::EWaveCreateSessionRequest request;
  *request.mutable_config() = proto_config(engine_config());
  v1::EWaveSessionResponse reply;
  auto c = context();
  ASSERT_TRUE(stub->CreateSession(c.get(), request, &reply).ok());
  auto announced = c->GetServerInitialMetadata().find(rpc::kSessionKey);
  ASSERT_NE(announced, c->GetServerInitialMetadata().end());
  EXPECT_EQ(std::string(announced->second.data(), announced->second.size()), reply.session_id());
  Session(*stub, reply.session_id()).close();
}

// A session tells its longest step: with the trim on, the period of the grid's shortest wave (2 pi /
// omega at k = pi sqrt(2) / dx, 0.0952 s for 1 cm cells in deep water): a step that long is taken, a longer
// one refused; untrimmed, 1e4 s.
TEST(EWaveService, ASessionTellsItsLongestStep) {
  test::InProcess<rpc::EWaveService> server;
  auto stub = v1::EWave::NewStub(server.channel());
  for (bool trim : {true, false}) {
    v1::EWaveCreateSessionRequest request;
    *request.mutable_config() = proto_config(engine_config());
    request.mutable_config()->set_trim(trim);
    request.mutable_config()->set_dx(0.01), request.mutable_config()->set_dy(0.01);
    v1::EWaveSessionResponse reply;
    ASSERT_TRUE(stub->CreateSession(context().get(), request, &reply).ok());
    const double period = 2 * M_PI / std::sqrt(9.81 * M_PI * std::sqrt(2.0) / 0.01);
    EXPECT_NEAR(reply.max_dt(), trim ? period : 1e4, trim ? 1e-6 : 0) << "trim " << trim;
    Session session(*stub, reply.session_id());
    v1::EWaveFrame f;
    EXPECT_TRUE(session.step(plain_inputs(reply.max_dt()), &f).ok());
    if (trim) {
      const grpc::Status status = session.step(plain_inputs(1.01 * reply.max_dt()), &f);
      EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
      EXPECT_NE(status.error_message().find("inputs.dt = "), std::string::npos) << status.error_message();
    }
    session.close();
  }
}

TEST(EWaveService, DrainingRefusesNewCallsAsUnavailable) {
  test::InProcess<rpc::EWaveService> server;
  auto stub = v1::EWave::NewStub(server.channel());
  Session s(*stub, proto_config(engine_config()));
  ASSERT_TRUE(s.status().ok());
  server.serving().set_phase(rpc::ServingState::Phase::Draining);
  v1::EWaveFrame f;
  grpc::Status status = s.step(plain_inputs(0.01), &f);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE) << status.error_message();
  EXPECT_NE(status.error_message().find("shutting down"), std::string::npos) << status.error_message();
  server.serving().set_phase(rpc::ServingState::Phase::Serving);
}

// While draining, a call whose x-squall-session names a session live here goes on (until the session has
// moved to another replica); a header naming no live session, however it looks, lets nothing through.
TEST(EWaveService, DrainingLetsThroughOnlyCallsNamingALiveSession) {
  test::InProcess<rpc::EWaveService> server;
  auto stub = v1::EWave::NewStub(server.channel());
  Session s(*stub, proto_config(engine_config()));
  ASSERT_TRUE(s.status().ok());
  Session closed(*stub, proto_config(engine_config()));
  ASSERT_TRUE(closed.close().ok());
  server.serving().set_phase(rpc::ServingState::Phase::Draining);
  for (const std::string& header : {s.id(), closed.id(), std::string("not-a-session")}) {
    auto ctx = context();
    ctx->AddMetadata("x-squall-session", header);
    v1::EWaveStepRequest request;
    request.set_session_id(s.id());
    *request.mutable_inputs() = plain_inputs(0.01);
    v1::EWaveFrame f;
    const grpc::Status status = stub->Step(ctx.get(), request, &f);
    if (header == s.id()) {
      EXPECT_TRUE(status.ok()) << status.error_message();
    } else {
      EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE) << header << ": " << status.error_message();
      EXPECT_NE(status.error_message().find("shutting down"), std::string::npos) << status.error_message();
    }
  }
  server.serving().set_phase(rpc::ServingState::Phase::Serving);
}

// Opens a Run stream and completes one step on it.
struct OpenRun {
  std::unique_ptr<grpc::ClientContext> ctx = context();
  std::unique_ptr<grpc::ClientReaderWriter<v1::EWaveStepRequest, v1::EWaveFrame>> call;
  bool stepped = false;
  OpenRun(Daemon& d, const std::string& id) {
    call = d.stub().Run(ctx.get());
    v1::EWaveStepRequest r;
    r.set_session_id(id);
    *r.mutable_inputs() = plain_inputs(0.01);
    v1::EWaveFrame f;
    stepped = call->Write(r) && call->Read(&f);
  }
};

TEST(EWaveService, ACancelledRunReleasesItsStreamSlot) {
  Session s(first().stub(), proto_config(engine_config()));  // --max-streams 2
  OpenRun a(first(), s.id()), b(first(), s.id());
  ASSERT_TRUE(a.stepped && b.stepped);
  {
    OpenRun c(first(), s.id());
    EXPECT_FALSE(c.stepped);
    grpc::Status status = c.call->Finish();
    EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
    EXPECT_NE(status.error_message().find("--max-streams"), std::string::npos) << status.error_message();
  }
  a.ctx->TryCancel();  // the client goes away mid-stream
  EXPECT_EQ(a.call->Finish().error_code(), grpc::StatusCode::CANCELLED);
  bool reopened = false;
  for (int tries = 0; tries < 50 && !reopened; ++tries) {  // the server notices the cancel asynchronously
    OpenRun d(first(), s.id());
    reopened = d.stepped;
    if (reopened) {
      d.call->WritesDone();
      EXPECT_TRUE(d.call->Finish().ok());
    } else {
      d.call->Finish();
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  }
  EXPECT_TRUE(reopened) << "the cancelled stream's slot was not released";
  b.call->WritesDone();
  EXPECT_TRUE(b.call->Finish().ok());
}

// The default step is one cell per step, within the session's longest step: at 5 cm/s over 1 cm cells that
// is 0.2 s, past the trimmed grid's 0.095 s, and the wake was refused at its first step.
TEST(EWaveCli, ASlowWakeStepsWithinTheSessionsLongestStep) {
  std::string out;
  const int rc = test::run(
      {kSquall, "--address", first().address(), "ewave", "wake", "--speed", "0.05", "--steps", "2", "--every", "2",
       "--grid", "64x32", "--spacing", "0.01", "--outputs", "height", "-o", test::temp_dir("ewave-slow-wake")},
      &out, 120);
  ASSERT_EQ(rc, 0) << out;
  EXPECT_NE(out.find("wrote 1 frames of 2 steps"), std::string::npos) << out;
  // Every 2^64 - 1 steps: the last step alone is written, and counted.
  ASSERT_EQ(test::run({kSquall, "--address", first().address(), "ewave", "wake", "--speed", "0.05", "--steps", "2",
                       "--every", "18446744073709551615", "--grid", "64x32", "--spacing", "0.01", "-o",
                       test::temp_dir("ewave-wake-every")},
                      &out, 120),
            0)
      << out;
  EXPECT_NE(out.find("wrote 1 frames of 2 steps"), std::string::npos) << out;
}

// create_session (the CLI's creating calls) after a create whose answer was lost, so that gRPC made it again
// under the same proposed id and squalld answered ALREADY_EXISTS: the session the first attempt made is
// closed and the session made again under a fresh id. A create the client gave up on (DEADLINE_EXCEEDED,
// the session made all the same) is closed.
TEST(EWaveCli, ACreateWhoseAnswerWasLostIsClosedAndMadeAgain) {
  const client::Client c({first().address(), 30});
  auto stub = v1::EWave::NewStub(c.channel());
  v1::EWaveCreateSessionRequest request;
  *request.mutable_config() = proto_config(engine_config());
  std::vector<std::string> proposed;
  auto create_twice = [&](const std::string& id) {  // the first time, as a retry of a lost answer would
    proposed.push_back(id);
    v1::EWaveSessionResponse reply;
    grpc::Status status = stub->CreateSession(c.context(id).get(), request, &reply);
    if (proposed.size() == 1 && status.ok()) status = stub->CreateSession(c.context(id).get(), request, &reply);
    return status;
  };
  auto close = [&](const std::string& id) {
    v1::EWaveSessionRequest session;
    session.set_session_id(id);
    v1::EWaveCloseResponse closed;
    return stub->CloseSession(c.context(id).get(), session, &closed);
  };
  auto exists = [&](const std::string& id) {
    v1::EWaveSessionRequest session;
    session.set_session_id(id);
    v1::EWaveStateResponse state;
    return stub->GetState(c.context(id).get(), session, &state).error_code() != grpc::StatusCode::NOT_FOUND;
  };
  std::string id;
  const grpc::Status made = client::create_session("", create_twice, close, &id);
  ASSERT_TRUE(made.ok()) << made.error_message();
  ASSERT_EQ(proposed.size(), 2u);
  EXPECT_EQ(id, proposed[1]);
  EXPECT_FALSE(exists(proposed[0])) << "the session of the lost answer was left to its TTL";
  EXPECT_TRUE(exists(id));
  EXPECT_TRUE(close(id).ok());

  auto given_up = [&](const std::string& id) {
    v1::EWaveSessionResponse reply;
    EXPECT_TRUE(stub->CreateSession(c.context(id).get(), request, &reply).ok());
    return grpc::Status(grpc::StatusCode::DEADLINE_EXCEEDED, "Deadline Exceeded");
  };
  EXPECT_EQ(client::create_session("", given_up, close, &id).error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
  EXPECT_FALSE(exists(id)) << "the session made after the client gave up was left to its TTL";
}

// A wake the server refuses (a grid of one row) exits 4 and leaves no empty folder behind; a flag its hull
// does not use exits 2 naming it.
TEST(EWaveCli, ARefusedWakeLeavesNoFolder) {
  const std::string dir = test::temp_dir("ewave-refused-wake") + "/frames";
  std::string out;
  EXPECT_EQ(
      test::run({kSquall, "--address", first().address(), "ewave", "wake", "--grid", "64x1", "-o", dir}, &out, 120), 4)
      << out;
  EXPECT_FALSE(std::filesystem::exists(dir)) << out;
  EXPECT_EQ(test::run({kSquall, "--address", first().address(), "ewave", "wake", "--hull", "circle", "--beam", "0.1",
                       "-o", dir},
                      &out),
            2)
      << out;
  EXPECT_NE(out.find("--beam is not a flag of a circle hull"), std::string::npos) << out;
  EXPECT_EQ(test::run({kSquall, "--address", first().address(), "ewave", "wake", "--grid", "8x8x8", "-o", dir}, &out),
            2)
      << out;
  EXPECT_NE(out.find("--grid 8x8x8: must be NXxNY"), std::string::npos) << out;
  for (const char* dt : {"0", "-1"}) {  // a step of no time, or back in time, is no step
    EXPECT_EQ(test::run({kSquall, "--address", first().address(), "ewave", "wake", "--dt", dt, "-o", dir}, &out), 2)
        << out;
    EXPECT_NE(out.find("--dt " + std::string(dt) + ": must be > 0 s"), std::string::npos) << out;
  }
  EXPECT_FALSE(std::filesystem::exists(dir)) << out;
}

TEST(EWaveCli, WakeWritesExrFramesThatOpenExrReads) {
  std::string dir = test::temp_dir("ewave-wake");
  std::string out;
  int rc = test::run({kSquall,
                      "--address",
                      first().address(),
                      "ewave",
                      "wake",
                      "--speed",
                      "0.2",
                      "--hull",
                      "ellipse",
                      "--length",
                      "0.12",
                      "--beam",
                      "0.04",
                      "--steps",
                      "12",
                      "--every",
                      "6",
                      "--grid",
                      "96x64",
                      "--spacing",
                      "0.01",
                      "--outputs",
                      "normal_x,normal_y,normal_z,height",
                      "-o",
                      dir},
                     &out, 120);
  ASSERT_EQ(rc, 0) << out;
  EXPECT_NE(out.find("wrote 2 frames of 12 steps"), std::string::npos) << out;
  EXPECT_TRUE(std::filesystem::exists(dir + "/frame_00006.png"));
  EXPECT_FALSE(std::filesystem::exists(dir + "/frame_00005.exr"));
  Imf::InputFile file((dir + "/frame_00012.exr").c_str());
  Imath::Box2i window = file.header().dataWindow();
  ASSERT_EQ(window.max.x - window.min.x + 1, 96);
  ASSERT_EQ(window.max.y - window.min.y + 1, 64);
  std::vector<std::vector<float>> channels(4, std::vector<float>(96 * 64));
  Imf::FrameBuffer frame;
  const char* names[] = {"height", "normal_x", "normal_y", "normal_z"};  // not the order asked
  for (int c = 0; c < 4; ++c) {
    ASSERT_NE(file.header().channels().findChannel(names[c]), nullptr) << names[c];
    frame.insert(names[c], Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(channels[c].data()), 4, 4 * 96));
  }
  file.setFrameBuffer(frame);
  file.readPixels(window.min.y, window.max.y);
  // The hull (a source S0 (1 - O), S0 = 1 m/s) has raised waves; the normals, split into three channels, are
  // unit vectors cell by cell (steep at the hull's edge: the source pumps 5 cm per step there).
  EXPECT_GT(ewave::test::max_abs(channels[0]), 1e-4);
  for (size_t i = 0; i < channels[1].size(); ++i) {
    double x = channels[1][i], y = channels[2][i], z = channels[3][i];
    ASSERT_NEAR(x * x + y * y + z * z, 1.0, 1e-5) << i;
  }
  // The attributes name the flags without their dashes; the preview is the height, whichever field came first.
  const auto* speed = file.header().findTypedAttribute<Imf::StringAttribute>("squall.ewave.wake.speed");
  ASSERT_NE(speed, nullptr);
  EXPECT_EQ(speed->value(), "0.2");
  const std::string expected = dir + "/expected.png";
  client::write_png_preview(expected, 96, 64, channels[0]);
  EXPECT_EQ(test::read_file(dir + "/frame_00012.png"), test::read_file(expected)) << "the preview is not the height";
  // The session was closed at the end: all three --max-sessions slots are free again.
  std::vector<std::unique_ptr<Session>> live;
  for (int n = 0; n < 3; ++n) {
    live.push_back(std::make_unique<Session>(first().stub(), proto_config(engine_config())));
    EXPECT_TRUE(live.back()->status().ok()) << live.back()->status().error_message();
  }
}

}  // namespace
}  // namespace squall
