// AdvectInteractive and textures that follow the water, through a real squalld: an unsteered interactive
// stream equals AdvectTexture bit for bit; a steered velocity and dt move the texture by the measured amount
// from the next frame on; a texture following an eWave session moves with its surface current grad phi, one
// following an ocean tile with its drift; bad messages, tiles and unknown sessions get the documented
// errors and the daemon keeps serving.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <regex>

#include "client/client.h"
#include "common/field_codec.h"
#include "metrics.h"
#include "service_support.h"
#include "squall/v1/ewave.grpc.pb.h"
#include "support/expect_error.h"
#include "support/process.h"

namespace squall {
namespace {

using namespace squall::textures_test;
constexpr double kPi = 3.14159265358979323846;

v1::VelocitySpec uniform(double vx, double vy) {
  v1::VelocitySpec v;
  v.mutable_named()->set_kind(v1::AnalyticVelocity::KIND_UNIFORM);
  v.mutable_named()->set_velocity_x(vx);
  v.mutable_named()->set_velocity_y(vy);
  return v;
}

// Still 3-band noise (SUM_BANDS), two periods across a square region of `side` du at (x0, y0), 64 x 64
// pixels: one final plane.
v1::AdvectTextureRequest still_noise(v1::TextureMethod method, double x0, double y0, double side) {
  v1::AdvectTextureRequest r;
  r.set_method(method);
  r.mutable_texture()->mutable_noise()->set_bands(3);
  r.mutable_texture()->set_scale(2 / side);
  r.mutable_texture()->set_final_function(v1::FINAL_FUNCTION_SUM_BANDS);
  r.mutable_output()->set_width(64);
  r.mutable_output()->set_height(64);
  auto* region = r.mutable_output()->mutable_region();
  region->set_x0(x0);
  region->set_y0(y0);
  region->set_x1(x0 + side);
  region->set_y1(y0 + side);
  r.set_dt(0.1);
  return r;
}

test::Image final_plane(const v1::TextureFrame& f) {
  return {int(f.planes(0).nx()), int(f.planes(0).ny()), field::decode(f.planes(0), "final")};
}

// The displacement (pixels) from frame a to frame b, over the central 32 x 32 pixels.
test::Displacement motion(const v1::TextureFrame& a, const v1::TextureFrame& b) {
  test::Displacement d = test::phase_correlation(final_plane(a), final_plane(b), 16, 16, 32);
  EXPECT_TRUE(d.valid);
  return d;
}

TEST(TexturesInteractive, UnsteeredStreamEqualsAdvectTexture) {
  v1::AdvectTextureRequest r = noise_request(5);
  Streamed want = advect(r);
  ASSERT_TRUE(want.status.ok()) << want.status.error_message();
  Interactive s;
  ASSERT_TRUE(s.send(start(r, 2), 2));
  ASSERT_TRUE(s.send(more(0), 0));
  ASSERT_TRUE(s.send(more(3), 3));
  ASSERT_TRUE(s.finish().ok());
  ASSERT_EQ(s.frames().size(), want.frames.size());
  for (size_t i = 0; i < want.frames.size(); ++i) {
    const v1::TextureFrame &got = s.frames()[i], &ref = want.frames[i];
    EXPECT_EQ(got.index(), ref.index());
    EXPECT_EQ(got.time(), ref.time());
    ASSERT_EQ(got.planes_size(), ref.planes_size());
    for (int k = 0; k < got.planes_size(); ++k) EXPECT_EQ(got.planes(k).data(), ref.planes(k).data()) << i << " " << k;
  }
}

// Uniform 0.2 du/s along +x, then along -y, then at dt 0.2: each frame pair moves by v dt / pixel.
TEST(TexturesInteractive, SteeredVelocityAndDtTakeEffectAtTheNextFrame) {
  for (auto method : {v1::TEXTURE_METHOD_LAGRANGIAN_GRIDS, v1::TEXTURE_METHOD_TWO_PHASE_FLOW_MAP}) {
    v1::AdvectTextureRequest r = still_noise(method, 0, 0, 1);
    *r.mutable_velocity() = uniform(0.2, 0);
    r.mutable_eulerian()->add_latencies(4.0);  // the flow map regenerates after the frames below
    Interactive s;
    ASSERT_TRUE(s.send(start(r, 2), 2));
    v1::TextureControl turn = more(2);
    *turn.mutable_velocity() = uniform(0, -0.2);
    ASSERT_TRUE(s.send(turn, 2));
    v1::TextureControl slower = more(1);
    slower.set_dt(0.2);
    ASSERT_TRUE(s.send(slower, 1));
    ASSERT_TRUE(s.finish().ok());
    const auto& f = s.frames();
    ASSERT_EQ(f.size(), 5u);
    const double step = 0.2 * 0.1 * 64;  // px per frame at dt 0.1
    struct Expect {
      size_t from;
      double dx, dy;
    };
    for (Expect e : {Expect{0, step, 0}, Expect{1, 0, -step}, Expect{2, 0, -step}, Expect{3, 0, -2 * step}}) {
      test::Displacement d = motion(f[e.from], f[e.from + 1]);
      EXPECT_NEAR(d.dx, e.dx, 0.1) << "method " << method << " frames " << e.from << "-" << e.from + 1;
      EXPECT_NEAR(d.dy, e.dy, 0.1) << "method " << method << " frames " << e.from << "-" << e.from + 1;
    }
    EXPECT_NEAR(f[3].time() - f[2].time(), 0.1, 1e-12);
    EXPECT_NEAR(f[4].time() - f[3].time(), 0.2, 1e-12);
  }
}

// An eWave session of n x n cells (64 unless given) over 2 m x 2 m whose potential
// phi = (U L / 2 pi) sin(2 pi x / L) gives the surface current u = U cos(2 pi x / L), v = 0; nothing steps it,
// so the current is steady. Under the `proposed` id, if one is given.
std::string still_current_session(double U, uint32_t n = 64, const std::string& proposed = "") {
  const double L = 2.0;
  v1::EWaveCreateSessionRequest create;
  auto* c = create.mutable_config();
  c->set_nx(n);
  c->set_ny(n);
  c->set_dx(L / n);
  c->set_dy(L / n);
  std::vector<float> phi(n * n);
  for (uint32_t j = 0; j < n; ++j)
    for (uint32_t i = 0; i < n; ++i) phi[i + n * j] = float(U * L / (2 * kPi) * std::sin(2 * kPi * (i + 0.5) / n));
  field::encode({"phi", "m^2/s", n, n, 0, v1::DTYPE_FLOAT32}, phi, c->mutable_initial_phi());
  client::Client client({daemon().address(), 60, ""});
  auto ewave = v1::EWave::NewStub(client.channel());
  auto context = client.context(proposed);
  v1::EWaveSessionResponse session;
  grpc::Status status = ewave->CreateSession(context.get(), create, &session);
  EXPECT_TRUE(status.ok()) << status.error_message();
  return session.session_id();
}

// Around x = L/2 the current is -U (cos pi = -1, within 2% over the window): with U = 0.05 m/s and
// dt = 0.1 s the texture moves by -0.005 m = -1.28 px per frame, for AdvectTexture and AdvectInteractive.
TEST(TexturesEWave, TextureFollowsTheSessionsSurfaceCurrent) {
  const std::string id = still_current_session(0.05);
  v1::AdvectTextureRequest r = still_noise(v1::TEXTURE_METHOD_LAGRANGIAN_GRIDS, 0.875, 0.875, 0.25);
  r.mutable_velocity()->set_ewave_session(id);
  r.set_frames(3);
  Streamed streamed = advect(r);
  ASSERT_TRUE(streamed.status.ok()) << streamed.status.error_message();
  Interactive s;
  ASSERT_TRUE(s.send(start(r, 3), 3));
  ASSERT_TRUE(s.finish().ok());
  using Frames = const std::vector<v1::TextureFrame>*;
  for (Frames frames : {Frames(&streamed.frames), Frames(&s.frames())}) {
    ASSERT_EQ(frames->size(), 3u);
    for (size_t i = 0; i + 1 < 3; ++i) {
      test::Displacement d = motion((*frames)[i], (*frames)[i + 1]);
      EXPECT_NEAR(d.dx, -1.28 * 0.995, 0.08) << "frames " << i << "-" << i + 1;
      EXPECT_NEAR(d.dy, 0, 0.08);
    }
  }
}

// Closes eWave session `id` (EWave.CloseSession, routed by the id).
grpc::Status close_session(const std::string& id) {
  client::Client client({daemon().address(), 60, ""});
  v1::EWaveSessionRequest request;
  request.set_session_id(id);
  v1::EWaveCloseResponse reply;
  return v1::EWave::NewStub(client.channel())->CloseSession(client.context(id).get(), request, &reply);
}

// An interactive stream of `r`, which follows session `id`, sends a frame; then the session is closed and made
// again under its id with a current of speed U on n x n cells, and the stream asked for one more frame: the
// status it ends with, after its one frame.
grpc::Status one_more_frame_after_remaking(const v1::AdvectTextureRequest& r, const std::string& id, double U,
                                           uint32_t n) {
  Interactive s;
  EXPECT_TRUE(s.send(start(r, 1), 1));
  EXPECT_TRUE(close_session(id).ok());
  EXPECT_EQ(still_current_session(U, n, id), id);
  s.send(more(1), 1);
  const grpc::Status status = s.finish();
  EXPECT_EQ(s.frames().size(), 1u);
  return status;
}

// A stream's substeps are checked against the current of its first frame, and the current it follows is
// checked again at each read: where the session now holds a current whose gradients (U 2 pi / L = 1260 /s,
// 126 rad per frame of 0.1 s) the integration cannot follow, the next frame is refused naming the session; a
// stream that starts on that current is refused naming its substeps.
TEST(TexturesEWave, AFollowedCurrentThatTurnsTooFastForTheSubstepsIsRefused) {
  const std::string id = still_current_session(0.05, 64, std::string(31, 'e') + "f");
  v1::AdvectTextureRequest r = still_noise(v1::TEXTURE_METHOD_LAGRANGIAN_GRIDS, 0.875, 0.875, 0.25);
  r.mutable_velocity()->set_ewave_session(id);
  const grpc::Status status = one_more_frame_after_remaking(r, id, 400, 64);
  test::expect_error(Code::FailedPrecondition,
                     "control[0].start.velocity.ewave_session: its current now turns the flow by 1",
                     [&] { throw_status(status); });
  // From the first frame: the request's substeps are too few for the current it follows.
  r.set_frames(2);
  test::expect_error(Code::InvalidArgument, "request.substeps = 1: the velocity field turns by 1",
                     [&] { throw_status(advect(r).status); });
  EXPECT_TRUE(close_session(id).ok()) << "the id is free for a run of this test again";
}

// A stream is validated and its memory reserved for the grid of the session it follows: where that session is
// closed and one of another grid made under its id, the next frame is refused rather than advected by the
// new session's current unreserved. A control naming the session again follows the new one.
TEST(TexturesEWave, AStreamFollowsTheSessionWhoseGridItWasSizedFor) {
  const std::string id = still_current_session(0.05, 64, std::string(32, 'e'));
  v1::AdvectTextureRequest r = still_noise(v1::TEXTURE_METHOD_LAGRANGIAN_GRIDS, 0.875, 0.875, 0.25);
  r.mutable_velocity()->set_ewave_session(id);
  Interactive again;
  ASSERT_TRUE(again.send(start(r, 1), 1));
  const grpc::Status status = one_more_frame_after_remaking(r, id, 0.05, 128);
  test::expect_error(Code::Aborted,
                     "control[0].start.velocity.ewave_session names a session of 128 x 128 cells of 0.015625 x "
                     "0.015625 m now, not the one of 64 x 64 cells of 0.03125 x 0.03125 m that the stream began to "
                     "follow",
                     [&] { throw_status(status); });
  v1::TextureControl follow = more(2);
  follow.mutable_velocity()->set_ewave_session(id);
  ASSERT_TRUE(again.send(follow, 2)) << "a control that names it again follows the new session";
  ASSERT_TRUE(again.finish().ok());
  EXPECT_EQ(again.frames().size(), 3u);
  EXPECT_TRUE(close_session(id).ok()) << "the id is free for a run of this test again";
}

// A Phillips layer of amplitude 0 (no waves) drifting at U_D: the current is U_D everywhere, and the
// texture moves by U_D dt per frame (0.2, 0.1 du/s at dt 0.1 over 64 px/du: 1.28, 0.64 px).
v1::TileSpec still_water(double drift_x, double drift_y) {
  v1::TileSpec tile;
  auto* layer = tile.add_layers();
  layer->set_extent_x(1);
  layer->set_extent_y(1);
  layer->set_nx(16);
  layer->set_ny(16);
  layer->set_spectrum(v1::SPECTRUM_MODEL_PHILLIPS);
  layer->set_dispersion(v1::DISPERSION_MODEL_DEEP);
  layer->set_wind_speed(5);
  layer->set_phillips_amplitude(0);
  layer->set_drift_x(drift_x);
  layer->set_drift_y(drift_y);
  return tile;
}

TEST(TexturesOcean, TextureDriftsWithTheOceansCurrent) {
  v1::AdvectTextureRequest r = still_noise(v1::TEXTURE_METHOD_LAGRANGIAN_GRIDS, 0, 0, 1);
  *r.mutable_velocity()->mutable_ocean() = still_water(0.2, 0.1);
  r.set_frames(3);
  Streamed s = advect(r);
  ASSERT_TRUE(s.status.ok()) << s.status.error_message();
  ASSERT_EQ(s.frames.size(), 3u);
  for (size_t i = 0; i + 1 < 3; ++i) {
    test::Displacement d = motion(s.frames[i], s.frames[i + 1]);
    EXPECT_NEAR(d.dx, 1.28, 0.1) << "frames " << i << "-" << i + 1;
    EXPECT_NEAR(d.dy, 0.64, 0.1) << "frames " << i << "-" << i + 1;
  }
  // The tile is validated like GetTile's, and its layers must share one drift.
  auto bad = r;
  bad.mutable_velocity()->mutable_ocean()->mutable_layers(0)->set_wind_speed(NAN);
  test::expect_error(Code::InvalidArgument, "request.velocity.ocean.layers[0].wind_speed = nan",
                     [&] { advect_or_throw(bad); });
  bad = r;
  *bad.mutable_velocity()->mutable_ocean()->add_layers() = r.velocity().ocean().layers(0);
  bad.mutable_velocity()->mutable_ocean()->mutable_layers(1)->set_drift_x(0.5);
  test::expect_error(Code::InvalidArgument, "request.velocity.ocean.layers[1].drift_x = 0.5 must be equal",
                     [&] { advect_or_throw(bad); });
  // A current grid finer than a velocity grid may be (1 mm over 2048 samples) is named as the ocean's grid,
  // not as a request.velocity.grid the request does not have.
  bad = r;
  bad.mutable_velocity()->mutable_ocean()->mutable_layers(0)->set_extent_x(0.001);
  bad.mutable_velocity()->mutable_ocean()->mutable_output()->set_nx(2048);
  bad.mutable_velocity()->mutable_ocean()->mutable_output()->set_ny(16);
  test::expect_error(Code::InvalidArgument, "request.velocity.ocean's grid.spacing.x = 4.88",
                     [&] { advect_or_throw(bad); });
  // The times are checked before the current is computed at them, and named as the client sent them.
  bad = r;
  bad.set_dt(-1);
  test::expect_error(Code::InvalidArgument, "request.dt = -1", [&] { advect_or_throw(bad); });
  bad = r;
  bad.set_t0(NAN);
  test::expect_error(Code::InvalidArgument, "request.t0 = nan", [&] { advect_or_throw(bad); });
}

// The layers of the ocean a texture follows are checked against the FFT backend's lengths before the stream
// starts, named as the client sent them (clFFT cannot transform 34 = 2 x 17; the stream took its slot and
// failed in the current's transform, naming no field). The same layer at 36 runs.
TEST(TexturesOcean, AFollowedOceansLayersHaveLengthsTheFftBackendTransforms) {
  test::Daemon d({"--fft", "clfft"});
  v1::AdvectTextureRequest r = still_noise(v1::TEXTURE_METHOD_LAGRANGIAN_GRIDS, 0, 0, 1);
  *r.mutable_velocity()->mutable_ocean() = still_water(0.2, 0.1);
  r.set_frames(2);
  r.mutable_velocity()->mutable_ocean()->mutable_layers(0)->set_nx(34);
  test::expect_error(Code::InvalidArgument, "request.velocity.ocean.layers[0].nx = 34: the clfft FFT backend",
                     [&] { throw_status(advect(r, d.address()).status); });
  r.mutable_velocity()->mutable_ocean()->mutable_layers(0)->set_nx(36);
  const Streamed s = advect(r, d.address());
  EXPECT_TRUE(s.status.ok()) << s.status.error_message();
  EXPECT_EQ(s.frames.size(), 2u);
}

// The spectra of the ocean a texture follows are reserved in the memory budget before they are built: under a
// budget of 16 MiB, which holds the stream, a 1024^2 layer's spectrum (24 MiB) is refused by name (it was
// built outside the budget); a 16^2 layer's runs.
TEST(TexturesOcean, TheFollowedOceansSpectraCountInTheMemoryBudget) {
  test::Daemon d({"--memory-budget", std::to_string(16 << 20)});
  v1::AdvectTextureRequest r = still_noise(v1::TEXTURE_METHOD_LAGRANGIAN_GRIDS, 0, 0, 1);
  *r.mutable_velocity()->mutable_ocean() = still_water(0.2, 0.1);
  r.set_frames(2);
  const Streamed small = advect(r, d.address());
  EXPECT_TRUE(small.status.ok()) << small.status.error_message();
  v1::TileSpec& waves = *r.mutable_velocity()->mutable_ocean();
  waves.mutable_layers(0)->set_nx(1024);
  waves.mutable_layers(0)->set_ny(1024);
  waves.mutable_output()->set_nx(16);
  waves.mutable_output()->set_ny(16);
  const grpc::Status refused = advect(r, d.address()).status;
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << refused.error_message();
  EXPECT_NE(
      refused.error_message().find("request.velocity.ocean's spectra (25165824 bytes) would pass the memory budget"),
      std::string::npos)
      << refused.error_message();
}

// A stream resumed from a checkpoint reads the ocean's current for the checkpoint's time (not t0): its
// frames equal the uninterrupted stream's bit for bit, under waves whose current changes every step.
TEST(TexturesOcean, ResumedStreamFollowsTheCurrentFromTheCheckpointsTime) {
  v1::AdvectTextureRequest r = still_noise(v1::TEXTURE_METHOD_LAGRANGIAN_GRIDS, 0, 0, 1);
  v1::TileSpec waves = still_water(0.05, 0);
  waves.mutable_layers(0)->clear_phillips_amplitude();  // the default 1e-3: real waves
  *r.mutable_velocity()->mutable_ocean() = waves;
  r.set_frames(4);
  r.set_checkpoint_every(2);
  Streamed through = advect(r);
  ASSERT_TRUE(through.status.ok()) << through.status.error_message();
  ASSERT_EQ(through.frames.size(), 4u);
  r.set_checkpoint_every(0);
  r.set_resume_state(through.frames[2].checkpoint());
  Streamed resumed = advect(r);
  ASSERT_TRUE(resumed.status.ok()) << resumed.status.error_message();
  ASSERT_EQ(resumed.frames.size(), 1u);
  EXPECT_EQ(resumed.frames[0].index(), 3u);
  EXPECT_EQ(resumed.frames[0].planes(0).data(), through.frames[3].planes(0).data());
  EXPECT_NE(through.frames[3].planes(0).data(), through.frames[2].planes(0).data());
}

// `squall texture advect --velocity ewave:ID` streams frames following the session, and names it in
// x-squall-session (squalld's request log shows it) for a session-affine proxy to route on; an unknown id
// fails with the NOT_FOUND message naming the field.
TEST(TexturesEWave, CommandLineFollowsASession) {
  const std::string dir = test::temp_dir("textures-cli-ewave"), id = still_current_session(0.05);
  auto advect_cli = [&](const std::string& velocity, std::string* out) {
    return test::run({test::squall_path(), "--address", daemon().address(), "texture", "advect", "--frames", "2",
                      "--size", "32x32", "--region", "0.875,0.875,1.125,1.125", "--velocity", velocity, "--out", dir},
                     out);
  };
  std::string out;
  ASSERT_EQ(advect_cli("ewave:" + id, &out), 0) << out;
  EXPECT_TRUE(std::filesystem::exists(dir + "/frame_0001.exr")) << out;
  const std::regex named("method=/squall\\.v1\\.Textures/AdvectTexture status=OK .* session=" + id);
  EXPECT_TRUE(std::regex_search(daemon().process().log(), named)) << "no AdvectTexture call named session " << id;
  EXPECT_NE(advect_cli("ewave:no-such-session", &out), 0);
  EXPECT_NE(out.find("request.velocity.ewave_session"), std::string::npos) << out;
}

TEST(TexturesEWave, UnknownSessionIsNotFound) {
  v1::AdvectTextureRequest r = still_noise(v1::TEXTURE_METHOD_NAIVE, 0, 0, 1);
  r.set_frames(2);
  r.mutable_velocity()->set_ewave_session("no-such-session");
  test::expect_error(Code::NotFound, "request.velocity.ewave_session: session_id = \"no-such-session\"",
                     [&] { advect_or_throw(r); });
  // Mid-stream: the frames before the bad message arrive, then the stream ends NOT_FOUND.
  r.clear_velocity();
  Interactive s;
  ASSERT_TRUE(s.send(start(r, 2), 2));
  v1::TextureControl follow = more(1);
  follow.mutable_velocity()->set_ewave_session("no-such-session");
  s.send(follow, 1);
  grpc::Status status = s.finish();
  EXPECT_EQ(s.frames().size(), 2u);
  test::expect_error(Code::NotFound, "control[1].velocity.ewave_session", [&] { throw_status(status); });
}

// A current followed past the +-1e9 du/s that advection takes is the session's state, not the request's:
// FAILED_PRECONDITION naming the field that follows the session, when the stream starts and when a frame
// reads the current again mid-stream. The session: 8 x 8 cells of 1 um, still; one step of dt = 1 s with
// a potential source of 1e6 sin(2 pi x / 8 um) m^2/s^2 leaves phi of that order, slopes near 1e11 m/s.
TEST(TexturesEWave, CurrentPastAdvectionsRangeIsTheSessionsStateNamedByItsField) {
  const uint32_t n = 8;
  const double dx = 1e-6;
  v1::EWaveCreateSessionRequest create;
  create.mutable_config()->set_nx(n);
  create.mutable_config()->set_ny(n);
  create.mutable_config()->set_dx(dx);
  create.mutable_config()->set_dy(dx);
  create.mutable_config()->set_trim(false);
  client::Client client({daemon().address(), 60, ""});
  auto ewave = v1::EWave::NewStub(client.channel());
  v1::EWaveSessionResponse session;
  grpc::Status status = ewave->CreateSession(client.context().get(), create, &session);
  ASSERT_TRUE(status.ok()) << status.error_message();

  v1::AdvectTextureRequest r = still_noise(v1::TEXTURE_METHOD_NAIVE, 0, 0, n * dx);
  r.clear_velocity();
  Interactive s;
  v1::TextureControl follow = start(r, 1);
  follow.mutable_start()->mutable_velocity()->set_ewave_session(session.session_id());
  ASSERT_TRUE(s.send(follow, 1));  // still water: no current

  v1::EWaveStepRequest step;
  step.set_session_id(session.session_id());
  step.mutable_inputs()->set_dt(1);
  std::vector<float> source(n * n);
  for (uint32_t k = 0; k < n * n; ++k) source[k] = float(1e6 * std::sin(2 * kPi * (k % n + 0.5) / n));
  field::encode({"source_phi", "m^2/s^2", n, n, 0, v1::DTYPE_FLOAT32}, source,
                step.mutable_inputs()->mutable_source_phi());
  v1::EWaveFrame frame;
  status = ewave->Step(client.context(session.session_id()).get(), step, &frame);
  ASSERT_TRUE(status.ok()) << status.error_message();

  s.send(more(1), 1);
  status = s.finish();
  EXPECT_EQ(s.frames().size(), 1u);
  const std::string past = "du/s, past the +-1e+09 du/s that advection takes";
  test::expect_error(Code::FailedPrecondition, "control[0].start.velocity.ewave_session: its current at node (",
                     [&] { throw_status(status); });
  test::expect_error(Code::FailedPrecondition, past, [&] { throw_status(status); });
  r.set_frames(2);
  r.mutable_velocity()->set_ewave_session(session.session_id());
  test::expect_error(Code::FailedPrecondition, "request.velocity.ewave_session: its current at node (",
                     [&] { advect_or_throw(r); });
}

// A still velocity grid of 2 x 2 nodes 1 du apart, with `frames` frames `apart` s apart from t = 0.
v1::VelocitySpec still_grid(int frames, double apart) {
  v1::VelocitySpec v;
  auto* g = v.mutable_grid();
  g->set_nx(2);
  g->set_ny(2);
  g->mutable_spacing()->set_x(1);
  g->mutable_spacing()->set_y(1);
  for (int i = 0; i < frames; ++i) {
    auto* frame = g->add_frames();
    frame->set_time(i * apart);
    *frame->mutable_u() = float_field("u", 2, 2, std::vector<float>(4, 0.0f));
    *frame->mutable_v() = float_field("v", 2, 2, std::vector<float>(4, 0.0f));
  }
  return v;
}

TEST(TexturesInteractive, BadMessagesGetClearErrors) {
  const v1::AdvectTextureRequest good = still_noise(v1::TEXTURE_METHOD_NAIVE, 0, 0, 1);
  struct Case {
    std::function<std::vector<v1::TextureControl>()> messages;
    Code code;
    std::string needle;
  };
  auto then = [&](std::function<void(v1::TextureControl&)> edit) {
    return [=] {
      v1::TextureControl second = more(1);
      edit(second);
      return std::vector<v1::TextureControl>{start(good, 1), second};
    };
  };
  std::vector<Case> cases = {
      {[] { return std::vector<v1::TextureControl>{more(1)}; }, Code::InvalidArgument, "control[0].start is unset"},
      {[&] {
         v1::TextureControl first = start(good, 1);
         first.mutable_start()->set_frames(5);
         return std::vector<v1::TextureControl>{first};
       },
       Code::InvalidArgument, "control[0].start.frames = 5"},
      {[&] {
         v1::TextureControl first = start(good, 1);
         first.mutable_start()->mutable_output()->set_width(0);
         return std::vector<v1::TextureControl>{first};
       },
       Code::InvalidArgument, "control[0].start.output.width = 0"},
      // The rest of the first message is checked before the current it follows is read.
      {[&] {
         v1::TextureControl first = start(good, 1);
         first.mutable_start()->set_method(v1::TEXTURE_METHOD_LAGRANGIAN_GRIDS);
         first.mutable_start()->mutable_lagrangian()->set_d(-1);
         first.mutable_start()->mutable_velocity()->set_ewave_session("no-such-session");
         return std::vector<v1::TextureControl>{first};
       },
       Code::InvalidArgument, "control[0].start.lagrangian.d = -1"},
      {[&] { return std::vector<v1::TextureControl>{start(good, 5000)}; }, Code::InvalidArgument,
       "control[0].frames = 5000"},
      {then([&](v1::TextureControl& c) { *c.mutable_start() = good; }), Code::InvalidArgument,
       "control[1].start is set"},
      {then([](v1::TextureControl& c) { c.set_dt(NAN); }), Code::InvalidArgument, "control[1].dt = nan"},
      {then([](v1::TextureControl& c) { c.set_substeps(0); }), Code::InvalidArgument, "control[1].substeps = 0"},
      {then([](v1::TextureControl& c) { *c.mutable_velocity() = uniform(INFINITY, 0); }), Code::InvalidArgument,
       "control[1].velocity.named.velocity_x = inf"},
      {then([](v1::TextureControl& c) { c.set_final_scale(NAN); }), Code::InvalidArgument,
       "control[1].final_scale = nan"},
      // A velocity is named where it was given: the first message's own, steered at once; the start's,
      // when a later message's dt makes its frames too close for one step.
      {[&] {
         v1::TextureControl first = start(good, 1);
         *first.mutable_velocity() = still_grid(2, 1);
         first.mutable_velocity()->mutable_grid()->mutable_spacing()->set_x(1e-7);
         return std::vector<v1::TextureControl>{first};
       },
       Code::InvalidArgument, "control[0].velocity.grid.spacing.x = 1e-07"},
      {[&] {
         v1::AdvectTextureRequest framed = good;
         *framed.mutable_velocity() = still_grid(9, 0.1);
         v1::TextureControl steer = more(1);
         steer.set_dt(1);
         return std::vector<v1::TextureControl>{start(framed, 1), steer};
       },
       Code::InvalidArgument, "control[0].start.velocity.grid.frames[7].time = 0.7"},
  };
  for (const auto& k : cases) {
    Interactive s;
    for (const auto& m : k.messages()) s.send(m, 0);
    grpc::Status status = s.finish();
    test::expect_error(k.code, k.needle, [&] { throw_status(status); });
  }
  // An image texture has no flow noise to spin.
  v1::AdvectTextureRequest image = good;
  *image.mutable_texture()->mutable_image()->add_channels() = float_field("a", 2, 2, {0, 1, 1, 0});
  Interactive s;
  ASSERT_TRUE(s.send(start(image, 1), 1));
  v1::TextureControl spin = more(1);
  spin.set_spin(1);
  s.send(spin, 1);
  grpc::Status status = s.finish();
  test::expect_error(Code::InvalidArgument, "control[1].spin = 1 must be unset", [&] { throw_status(status); });
  ASSERT_TRUE(daemon().running());
}

}  // namespace
}  // namespace squall
