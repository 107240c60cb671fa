// squall.v1.Clouds through a real squalld: build (kept, with .vdb bytes), render by id and by model,
// evolution stream, release, and the documented errors.
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <openvdb/io/Stream.h>

#include "client/client.h"
#include "client/image_io.h"
#include "clouds/build_memory.h"
#include "clouds/clouds_request.h"
#include "clouds/volume.h"
#include "squall/v1/clouds.grpc.pb.h"
#include "support/daemon.h"
#include "support/long_work.h"
#include "support/png_grey.h"

namespace squall {
namespace {

namespace v1 = squall::v1;
const std::string kSquall = test::squall_path();

test::Daemon& daemon() {
  static test::Daemon d({"--max-streams", "2"});
  return d;
}

struct Call {
  std::unique_ptr<client::Client> client;
  std::unique_ptr<v1::Clouds::Stub> stub;
  std::unique_ptr<grpc::ClientContext> context;

  grpc::Status build(const v1::BuildVolumeRequest& request, v1::BuildVolumeResponse* response) {
    return stub->BuildVolume(context.get(), request, response);
  }
  grpc::Status render(const v1::RenderRequest& request, v1::RenderResponse* response) {
    return stub->Render(context.get(), request, response);
  }
};

// A call to `address`: the shared daemon's unless another is named.
Call call(const std::string& address = daemon().address()) {
  Call c;
  c.client = std::make_unique<client::Client>(client::ClientOptions{address, 120, ""});
  c.stub = v1::Clouds::NewStub(c.client->channel());
  c.context = c.client->context();
  return c;
}

v1::CloudModel sphere_model() {
  v1::CloudModel m;
  m.set_voxel_size(0.5);
  m.set_skin(1.0);
  auto* s = m.add_spheres();
  s->set_radius(5);
  auto* p = m.mutable_pyroclastic();
  p->set_layers(1);
  p->set_amplitude(1);
  p->mutable_noise()->set_frequency(0.3);
  m.mutable_temperature()->set_enabled(true);
  return m;
}

v1::RenderSettings small_render() {
  v1::RenderSettings s;
  auto* c = s.mutable_camera();
  c->mutable_eye()->set_y(-30);
  c->mutable_up()->set_z(1);
  c->set_width(24);
  c->set_height(16);
  s.set_step(0.25);
  s.add_wavelengths(550e-9);
  s.add_wavelengths(10e-6);
  s.add_extinction(0.5);
  s.add_extinction(0.5);
  auto* l = s.add_lights();
  l->mutable_direction()->set_z(1);
  l->add_intensity(1000);
  l->add_intensity(0);
  return s;
}

TEST(CloudsService, BuildKeepRenderRelease) {
  auto c = call();
  v1::BuildVolumeRequest build;
  *build.mutable_model() = sphere_model();
  build.set_keep(true);
  build.set_return_vdb(true);
  v1::BuildVolumeResponse built;
  ASSERT_TRUE(c.stub->BuildVolume(c.context.get(), build, &built).ok());
  const auto& s = built.summary();
  EXPECT_FALSE(s.volume_id().empty());
  EXPECT_TRUE(s.has_temperature());
  EXPECT_DOUBLE_EQ(s.voxel_size(), 0.5);
  EXPECT_GT(s.active_voxels(), 4000u);  // (4/3) pi 10^3 voxels at least
  EXPECT_GT(s.device_bytes(), 0u);
  // The .vdb bytes read back with OpenVDB hold the same density grid.
  clouds::initialize_openvdb();
  std::istringstream in(built.vdb(), std::ios::binary);
  openvdb::io::Stream stream(in);
  auto grids = stream.getGrids();
  ASSERT_EQ(grids->size(), 2u);
  EXPECT_EQ((*grids)[0]->getName(), "density");
  EXPECT_EQ((*grids)[1]->getName(), "temperature");
  EXPECT_EQ((*grids)[0]->activeVoxelCount(), s.active_voxels());

  auto r = call();
  v1::RenderRequest render;
  render.set_volume_id(s.volume_id());
  *render.mutable_settings() = small_render();
  v1::RenderResponse image;
  auto status = r.stub->Render(r.context.get(), render, &image);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_EQ(image.image().channels_size(), 5);  // 2 radiance, 2 transmittance, depth
  EXPECT_EQ(image.image().data().size(), 24u * 16 * 5 * 4);
  std::vector<float> px(24 * 16 * 5);
  std::memcpy(px.data(), image.image().data().data(), image.image().data().size());
  // Transmittance at the image centre: the column through a radius-5 sphere with a 1 m skin is at least
  // 2R - skin = 9 m of unit density, at most 2 (R + 1 m of displacement) = 12 m: kappa 0.5 gives tau in [4.5, 6].
  float centre_t = px[(2 * 16 + 8) * 24 + 12];  // transmittance_0
  EXPECT_LT(centre_t, std::exp(-4.5) * 1.02);
  EXPECT_GT(centre_t, std::exp(-6.0));
  EXPECT_EQ(px[(2 * 16 + 0) * 24 + 0], 1.0f);  // a corner ray misses the cloud
  // 10 um: no light (intensity 0), emission only: L = (1 - albedo) B(T) (1 - T_10um) for the isothermal-ish
  // centre row (T = 288.15 K - 6.5 K/km * z, |z| < 0.3 m there), default albedo 0.9.
  const double h = 6.62607015e-34, cl = 299792458, kb = 1.380649e-23, lambda = 10e-6, T = 288.15;
  double B = 2 * h * cl * cl / std::pow(lambda, 5) / std::expm1(h * cl / (lambda * kb * T));
  float ir = px[(1 * 16 + 8) * 24 + 12];
  float ir_t = px[(3 * 16 + 8) * 24 + 12];  // transmittance_1
  EXPECT_NEAR(ir / ((1 - 0.9) * B * (1 - ir_t)), 1.0, 2e-3);

  auto rel = call();
  v1::ReleaseVolumeRequest release;
  release.set_volume_id(s.volume_id());
  v1::ReleaseVolumeResponse released;
  ASSERT_TRUE(rel.stub->ReleaseVolume(rel.context.get(), release, &released).ok());
  auto again = call();
  status = again.stub->Render(again.context.get(), render, &image);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_NE(status.error_message().find("volume_id"), std::string::npos) << status.error_message();
}

// A model inside every range whose density is zero everywhere (a particle biased to -1) builds a volume
// with no active voxel: its bounds are the origin's point, not OpenVDB's empty box (INT_MAX to INT_MIN), and
// it renders as empty space: transmittance 1, no radiance, no depth.
TEST(CloudsService, AVolumeWithNoActiveVoxelRendersAsEmptySpace) {
  v1::BuildVolumeRequest build;
  build.mutable_model()->set_voxel_size(0.5);
  auto* particle = build.mutable_model()->add_particles();
  particle->set_radius(3);
  particle->set_bias(-1);
  build.set_keep(true);
  v1::BuildVolumeResponse built;
  auto c = call();
  auto status = c.build(build, &built);
  ASSERT_TRUE(status.ok()) << status.error_message();
  const auto& s = built.summary();
  EXPECT_EQ(s.active_voxels(), 0u);
  for (const auto* corner : {&s.bounds_min(), &s.bounds_max()}) {
    EXPECT_EQ(corner->x(), 0.0);
    EXPECT_EQ(corner->y(), 0.0);
    EXPECT_EQ(corner->z(), 0.0);
  }
  v1::RenderRequest render;
  render.set_volume_id(s.volume_id());
  *render.mutable_settings() = small_render();
  for (auto shadow : {v1::SHADOW_MODE_DIRECT, v1::SHADOW_MODE_DEEP_SHADOW_MAP}) {
    render.mutable_settings()->set_shadow(shadow);
    v1::RenderResponse image;
    auto r = call();
    status = r.render(render, &image);
    ASSERT_TRUE(status.ok()) << status.error_message();
    std::vector<float> px(24 * 16 * 5);
    ASSERT_EQ(image.image().data().size(), px.size() * sizeof(float));
    std::memcpy(px.data(), image.image().data().data(), image.image().data().size());
    const size_t plane = 24 * 16;
    for (size_t i = 0; i < plane; ++i) {
      ASSERT_EQ(px[i], 0.0f) << i;               // radiance_0
      ASSERT_EQ(px[plane + i], 0.0f) << i;       // radiance_1
      ASSERT_EQ(px[2 * plane + i], 1.0f) << i;   // transmittance_0
      ASSERT_EQ(px[3 * plane + i], 1.0f) << i;   // transmittance_1
      ASSERT_EQ(px[4 * plane + i], -1.0f) << i;  // depth
    }
  }
}

// A StreamEvolution of sphere_model() (and `edit`'s changes) at `times`, small_render() frames: the frames
// it sent, and its status.
std::vector<v1::EvolutionFrame> evolve(const std::vector<double>& times,
                                       const std::function<void(v1::StreamEvolutionRequest&)>& edit,
                                       grpc::Status* status) {
  auto c = call();
  v1::StreamEvolutionRequest request;
  *request.mutable_model() = sphere_model();
  for (double t : times) request.add_times(t);
  *request.mutable_settings() = small_render();
  edit(request);
  auto reader = c.stub->StreamEvolution(c.context.get(), request);
  v1::EvolutionFrame frame;
  std::vector<v1::EvolutionFrame> frames;
  while (reader->Read(&frame)) frames.push_back(frame);
  *status = reader->Finish();
  return frames;
}

TEST(CloudsService, EvolutionStreamsOneFramePerTime) {
  grpc::Status status;
  const auto frames = evolve(
      {0.0, 1.0, 2.0}, [](v1::StreamEvolutionRequest& r) { r.mutable_evolution()->mutable_drift()->set_x(2); },
      &status);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_EQ(frames.size(), 3u);
  for (const auto& frame : frames) EXPECT_EQ(frame.image().width(), 24u);
  const double x0 = frames[0].summary().bounds_min().x();
  EXPECT_NEAR(frames[1].summary().bounds_min().x() - x0, 2.0, 1e-9);  // the cloud drifts 2 m/s
  EXPECT_NEAR(frames[2].summary().bounds_min().x() - x0, 4.0, 1e-9);
}

// Times before 0 are valid: advection time, like the pyroclastic amplitude, is clamped at 0. With
// advection_rate 1, the model at t = -1 is advected for 0 s as at t = 0 (not for 1 s, nor refused): the
// two frames hold the same voxels, and the frame at t = 1 others.
TEST(CloudsService, EvolutionAtNegativeTimesClampsTheAdvectionTime) {
  grpc::Status status;
  const auto frames = evolve(
      {-1.0, 0.0, 1.0},
      [](v1::StreamEvolutionRequest& r) {
        r.mutable_model()->mutable_advection()->set_speed(2);
        r.mutable_model()->mutable_advection()->mutable_noise()->set_frequency(0.2);
        r.mutable_evolution()->set_advection_rate(1);
      },
      &status);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_EQ(frames[1].summary().SerializeAsString(), frames[0].summary().SerializeAsString());
  EXPECT_NE(frames[2].summary().active_voxels(), frames[1].summary().active_voxels())
      << "advected for 1 s, the cloud changes";
}

// Every frame is checked before the first is sent, also where the checks are not monotone in t: with the
// amplitude falling to 0 at t = 1 and the advection on from t = 0, the frame at t = 0 is not advected and the
// one at 1 has no displacement, while the one at 0.5 has both: 2.7e9 velocity samples, past the daemon's
// 1e9, refused by name with no frame sent.
TEST(CloudsService, EvolutionFramesBetweenTwoClampsAreCheckedBeforeTheFirstIsSent) {
  grpc::Status status;
  const auto frames = evolve(
      {0.0, 0.5, 1.0},
      [](v1::StreamEvolutionRequest& r) {
        r.mutable_model()->set_voxel_size(1);
        r.mutable_model()->mutable_spheres(0)->set_radius(50);
        r.mutable_model()->mutable_pyroclastic()->set_amplitude(100);
        auto* advection = r.mutable_model()->mutable_advection();
        advection->set_speed(1);
        advection->set_substeps(256);
        advection->mutable_noise()->set_frequency(0.2);
        r.mutable_evolution()->set_amplitude_rate(-100);
        r.mutable_evolution()->set_advection_rate(1);
      },
      &status);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
  EXPECT_NE(status.error_message().find("model at times[1]"), std::string::npos) << status.error_message();
  EXPECT_TRUE(frames.empty());
}

// A frame's temperatures are checked as it is built, and the error names the frame: a cloud drifting up at
// 1000 m/s through a lapse of 0.1 K/m is at -712 K at t = 10 s.
TEST(CloudsService, AnEvolvedFramesTemperatureOutOfRangeNamesTheFrame) {
  grpc::Status status;
  const auto frames = evolve(
      {0.0, 10.0},
      [](v1::StreamEvolutionRequest& r) {
        r.mutable_model()->mutable_temperature()->set_lapse_rate(0.1);
        r.mutable_evolution()->mutable_drift()->set_z(1000);
      },
      &status);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
  EXPECT_NE(status.error_message().find("model at times[1].temperature makes temperatures from"), std::string::npos)
      << status.error_message();
  EXPECT_EQ(frames.size(), 1u);
}

TEST(CloudsService, BadRequestsGetClearErrors) {
  struct Case {
    std::function<void(v1::RenderRequest&)> edit;
    grpc::StatusCode code;
    std::string needle;
  };
  std::vector<Case> cases = {
      {[](v1::RenderRequest& r) { r.set_volume_id("cloud-404"); }, grpc::StatusCode::NOT_FOUND,
       "volume_id = \"cloud-404\""},
      {[](v1::RenderRequest& r) { r.mutable_model()->mutable_spheres(0)->set_radius(NAN); },
       grpc::StatusCode::INVALID_ARGUMENT, "model.spheres[0].radius = nan"},
      {[](v1::RenderRequest& r) {
         auto* m = r.mutable_model()->add_meshes();
         m->set_obj("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\nf 1 3 2\nf 1 4 3\n");
       },
       grpc::StatusCode::INVALID_ARGUMENT, "model.meshes[0] is degenerate"},
      {[](v1::RenderRequest& r) { r.mutable_model()->set_max_active_voxels(100); },
       grpc::StatusCode::RESOURCE_EXHAUSTED, "model.max_active_voxels = 100"},
      {[](v1::RenderRequest& r) { r.mutable_settings()->set_step(-1); }, grpc::StatusCode::INVALID_ARGUMENT,
       "settings.step = -1"},
      {[](v1::RenderRequest& r) { r.mutable_model()->mutable_advection()->set_scheme(v1::AdvectionScheme(7)); },
       grpc::StatusCode::INVALID_ARGUMENT, "model.advection.scheme = 7 must be a known AdvectionScheme"},
      {[](v1::RenderRequest& r) { r.mutable_model()->mutable_spheres(0)->mutable_center()->set_x(1e300); },
       grpc::StatusCode::INVALID_ARGUMENT, "model.spheres[0].center = (1e+300, 0, 0) plus"},
      {[](v1::RenderRequest& r) { r.set_volume_id(std::string(1 << 20, 'x')); }, grpc::StatusCode::NOT_FOUND,
       "volume_id = \"xxxxxxxx"},
      {[](v1::RenderRequest& r) { r.set_volume_id("cloud-\n404"); }, grpc::StatusCode::NOT_FOUND,
       "volume_id = \"cloud-\\x0a404\""},
  };
  for (const auto& k : cases) {
    v1::RenderRequest request;
    *request.mutable_model() = sphere_model();
    *request.mutable_settings() = small_render();
    k.edit(request);
    if (!request.volume_id().empty()) request.clear_model();
    auto c = call();
    v1::RenderResponse response;
    auto status = c.stub->Render(c.context.get(), request, &response);
    EXPECT_EQ(status.error_code(), k.code) << status.error_message();
    EXPECT_NE(status.error_message().find(k.needle), std::string::npos) << status.error_message();
    EXPECT_LT(status.error_message().size(), 600u) << "client strings are truncated in messages";
  }
}

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

void expire_in(grpc::ClientContext& context, double seconds) {
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::milliseconds(int64_t(seconds * 1000)));
}

// How long a render waits, past its own time, for a device that an expired render held: the slice in flight
// (about kSliceSeconds, at most a few times that) and the cancel reaching it, with room for a busy machine
// (ctest runs this binary with no other test beside it: another's load stretched a slice past 1 s once).
// Without slices the wait was the whole heavy render (13-17 s).
constexpr double kSliceBound = 1.0;

// Seconds `request` takes to render, which must succeed.
double timed_render(const v1::RenderRequest& request) {
  auto c = call();
  expire_in(*c.context, 60);
  v1::RenderResponse response;
  const auto start = std::chrono::steady_clock::now();
  const grpc::Status status = c.render(request, &response);
  EXPECT_TRUE(status.ok()) << status.error_message();
  return seconds_since(start);
}

// The sphere model kept as a volume: the renders below time the render alone, not the build.
std::string kept_sphere() {
  auto c = call();
  v1::BuildVolumeRequest build;
  *build.mutable_model() = sphere_model();
  build.set_keep(true);
  v1::BuildVolumeResponse built;
  const grpc::Status kept = c.build(build, &built);
  EXPECT_TRUE(kept.ok()) << kept.error_message();
  return built.summary().volume_id();
}

// A small render of the kept sphere alone, then a heavy render that its deadline (after `deadline` s) or its
// client (after `cancel_after` s, when > 0) ends, then the small render again: their times and how the heavy
// one ended.
struct EndedRender {
  double alone, after;
  grpc::Status status;
};
EndedRender end_a_heavy_render(double deadline, double cancel_after) {
  v1::RenderRequest small;
  small.set_volume_id(kept_sphere());
  *small.mutable_settings() = small_render();
  EndedRender r;
  r.alone = timed_render(small);
  v1::RenderRequest heavy = small;
  *heavy.mutable_settings() = test::long_render_settings();
  auto c = call();
  expire_in(*c.context, deadline);
  std::thread canceller([&] {
    if (cancel_after <= 0) return;
    std::this_thread::sleep_for(std::chrono::milliseconds(int64_t(cancel_after * 1000)));
    c.context->TryCancel();
  });
  v1::RenderResponse response;
  r.status = c.render(heavy, &response);
  canceller.join();
  r.after = timed_render(small);
  return r;
}

// A render whose deadline passes mid-way ends DEADLINE_EXCEEDED and leaves the device within a slice: a
// small render right after it takes at most kSliceBound longer than alone. Unsliced, a cancelled render
// held the device 13-17 s; sliced by tile count rather than cost, the empty sky's quick tiles grew the
// slices until one on the sphere held it 1.5 s past the deadline.
TEST(CloudsService, AnExpiredRenderFreesTheDeviceWithinASlice) {
  const EndedRender r = end_a_heavy_render(1.5, 0);
  EXPECT_EQ(r.status.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED) << r.status.error_message();
  EXPECT_LT(r.after, r.alone + kSliceBound)
      << "the expired render still held the device (the small render takes " << r.alone << " s alone)";
}

// A step of 1e-9 m through the sphere (a box about 20 m across) asks for some 1e15 samples: refused within
// a second, before any kernel runs (it used to hold the device for minutes), and the next render is served
// at once.
TEST(CloudsService, ARenderBeyondTheSampleBudgetIsRefusedAtOnce) {
  v1::RenderRequest request;
  request.set_volume_id(kept_sphere());
  *request.mutable_settings() = small_render();
  request.mutable_settings()->set_step(1e-9);
  auto c = call();
  v1::RenderResponse response;
  const auto start = std::chrono::steady_clock::now();
  const grpc::Status status = c.render(request, &response);
  EXPECT_LT(seconds_since(start), 1.0);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
  EXPECT_NE(status.error_message().find("settings.step = 1e-09 makes an estimated"), std::string::npos)
      << status.error_message();
  EXPECT_NE(status.error_message().find("--max-render-samples"), std::string::npos) << status.error_message();
  request.mutable_settings()->set_step(0.25);
  EXPECT_LT(timed_render(request), 1.0);
}

// A render its client cancels ends CANCELLED and leaves the device within a slice, as an expired one does.
TEST(CloudsService, ACancelledRenderFreesTheDeviceWithinASlice) {
  const EndedRender r = end_a_heavy_render(60, 1.5);
  EXPECT_EQ(r.status.error_code(), grpc::StatusCode::CANCELLED) << r.status.error_message();
  EXPECT_LT(r.after, r.alone + kSliceBound)
      << "the cancelled render still held the device (the small render takes " << r.alone << " s alone)";
}

// `model` in voxels of `voxel_size`, advected for 1 s at 1 m/s in 256 MacCormack substeps.
v1::BuildVolumeRequest advected_build(const v1::CloudModel& model, double voxel_size) {
  v1::BuildVolumeRequest build;
  *build.mutable_model() = model;
  build.mutable_model()->set_voxel_size(voxel_size);
  auto* advection = build.mutable_model()->mutable_advection();
  advection->set_speed(1);
  advection->set_time(1);
  advection->set_substeps(256);
  advection->set_scheme(v1::ADVECTION_SCHEME_MODIFIED_MACCORMACK);
  return build;
}

// A build with 256 advection substeps per voxel (about a minute of 2 cores) and a 1 s deadline: squalld
// stops working on it within a second of the deadline (it used to go on for more than 90 s).
TEST(CloudsService, AnExpiredBuildStopsUsingTheCores) {
  auto c = call();
  expire_in(*c.context, 1);
  v1::BuildVolumeResponse built;
  const grpc::Status expired = c.build(advected_build(sphere_model(), 0.25), &built);
  EXPECT_EQ(expired.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED) << expired.error_message();
  std::this_thread::sleep_for(std::chrono::seconds(1));
  const double before = daemon().process().cpu_seconds();
  std::this_thread::sleep_for(std::chrono::seconds(2));
  EXPECT_LT(daemon().process().cpu_seconds() - before, 0.5) << "squalld kept computing the expired build";
}

// 64 pixels at a 0.1 mm step with direct shadows every cm: 2.6e10 samples in all (admitted by
// --max-render-samples) but 4e8 per pixel, which one work-item would march for minutes with no way to stop
// it: refused, naming the step.
TEST(CloudsService, ARenderWhosePixelsAreTooCostlyIsRefused) {
  v1::RenderRequest request;
  *request.mutable_model() = test::long_work_sphere();
  *request.mutable_settings() = test::long_render_settings();
  request.mutable_settings()->mutable_camera()->set_width(8);
  request.mutable_settings()->mutable_camera()->set_height(8);
  request.mutable_settings()->set_step(1e-4);
  request.mutable_settings()->set_shadow_step(0.01);
  v1::RenderResponse response;
  const grpc::Status status = call().render(request, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
  EXPECT_NE(status.error_message().find("settings.step = 0.0001 makes an estimated"), std::string::npos)
      << status.error_message();
  EXPECT_NE(status.error_message().find("samples per pixel"), std::string::npos) << status.error_message();
}

// Each refusal names the step that drives what it counts. With a deep shadow map a pixel's march takes
// no shadow steps: 2 um steps through the sphere are 2e7 samples a pixel, refused naming the step though
// the shadow step is finer. And where the map's nodes cost more than the pixels (512^3 nodes, each a march
// in 3 mm steps across a box at least 10 m wide: over 7e11 samples), the render is refused naming the
// shadow step, though the primary step is finer.
TEST(CloudsService, ARefusedRenderNamesTheStepThatDrivesItsCost) {
  auto refused = [](const v1::RenderSettings& settings, const std::string& needle) {
    v1::RenderRequest request;
    *request.mutable_model() = test::long_work_sphere();
    *request.mutable_settings() = settings;
    v1::RenderResponse response;
    const grpc::Status status = call().render(request, &response);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
    EXPECT_NE(status.error_message().find(needle), std::string::npos) << status.error_message();
  };
  v1::RenderSettings s = test::long_render_settings();
  s.set_shadow(v1::SHADOW_MODE_DEEP_SHADOW_MAP);
  for (int a = 0; a < 3; ++a) s.add_shadow_map_size(2);
  s.mutable_camera()->set_width(8);
  s.mutable_camera()->set_height(8);
  s.set_step(2e-6);
  s.set_shadow_step(1e-6);
  refused(s, "settings.step = 2e-06 makes an estimated");
  refused(s, "density samples per pixel");
  for (int a = 0; a < 3; ++a) s.set_shadow_map_size(a, 512);
  s.set_step(0.002);
  s.set_shadow_step(0.003);
  refused(s, "settings.shadow_step = 0.003 makes an estimated");
  refused(s, "--max-render-samples = 4e+11 (a larger shadow step or a smaller shadow_map_size cost less)");
}

// The kernels march in float: a step that rounds back to where it started would never end its march and
// hold a device queue for good. Refused with the least step: a step and a shadow step of 1e-5 m across the
// sphere's box (about 24 m); a shadow step so fine that one map node's
// march could not be cancelled in time is refused first, as a pixel's is.
TEST(CloudsService, ARenderWhoseStepsFloatCannotResolveIsRefused) {
  v1::RenderRequest request;
  request.set_volume_id(kept_sphere());
  *request.mutable_settings() = small_render();
  for (int a = 0; a < 3; ++a) request.mutable_settings()->add_shadow_map_size(2);
  auto refused = [&](grpc::StatusCode code, const std::string& needle) {
    auto c = call();
    expire_in(*c.context, 30);
    v1::RenderResponse response;
    const grpc::Status status = c.render(request, &response);
    EXPECT_EQ(status.error_code(), code) << status.error_message();
    EXPECT_NE(status.error_message().find(needle), std::string::npos) << status.error_message();
  };
  request.mutable_settings()->set_step(1e-5);
  refused(grpc::StatusCode::INVALID_ARGUMENT,
          "settings.step = 1e-05 is below the float resolution of a march across "
          "the volume (");
  request.mutable_settings()->set_step(0.5);
  request.mutable_settings()->set_shadow_step(1e-5);
  refused(grpc::StatusCode::INVALID_ARGUMENT,
          "settings.shadow_step = 1e-05 is below the float resolution of a march across the volume toward a light");
  request.mutable_settings()->set_shadow_step(1e-6);
  refused(grpc::StatusCode::RESOURCE_EXHAUSTED, "density samples per deep shadow map node");
  request.mutable_settings()->set_shadow_step(0.05);
  EXPECT_LT(timed_render(request), 5.0);
}

// The same sphere seen from 2 km, from 20 km, where a node's 1e-4 voxel nudge is below a float ulp of
// the ray's distance, and from 10,000 km, as far as any point may be, at a step of half a voxel: each
// render ends, and the cloud covers some pixels.
TEST(CloudsService, ARenderFromFarAwayEnds) {
  v1::RenderRequest request;
  request.set_volume_id(kept_sphere());
  *request.mutable_settings() = small_render();
  request.mutable_settings()->set_step(0.5);
  for (double distance : {2e3, 2e4, 1e7}) {
    request.mutable_settings()->mutable_camera()->mutable_eye()->set_y(-distance);
    // The sphere fills most of the 16 rows.
    request.mutable_settings()->mutable_camera()->set_vertical_fov_deg(1000 / distance);
    auto c = call();
    expire_in(*c.context, 30);
    v1::RenderResponse response;
    const grpc::Status status = c.render(request, &response);
    ASSERT_TRUE(status.ok()) << distance << " m: " << status.error_message();
    const auto& image = response.image();
    const size_t pixels = size_t(image.width()) * image.height();
    std::vector<float> values(image.data().size() / sizeof(float));
    std::memcpy(values.data(), image.data().data(), values.size() * sizeof(float));
    size_t covered = 0;  // the first wavelength's transmittance plane follows the 2 radiance planes
    for (size_t p = 0; p < pixels; ++p) covered += values.at(2 * pixels + p) < 0.99f;
    EXPECT_GT(covered, 0u) << distance << " m";
  }
}

// A render's deep shadow map counts in --memory-budget beside its image: 512^3 nodes for 4 lights is 2 GiB
// of map (and 256 MiB of masks), refused under a budget of 1 GiB before anything is allocated, while the
// same render with a 64^3 map runs.
TEST(CloudsService, ARendersShadowMapCountsInTheMemoryBudget) {
  test::Daemon d({"--memory-budget", std::to_string(1ull << 30)});
  v1::RenderRequest request;
  *request.mutable_model() = sphere_model();
  *request.mutable_settings() = small_render();
  for (int light = 1; light < 4; ++light) *request.mutable_settings()->add_lights() = request.settings().lights(0);
  for (int a = 0; a < 3; ++a) request.mutable_settings()->add_shadow_map_size(512);
  v1::RenderResponse response;
  grpc::Status status = call(d.address()).render(request, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
  EXPECT_NE(
      status.error_message().find("Render's image and shadow map (2415942144 bytes) would pass the memory budget"),
      std::string::npos)
      << status.error_message();
  for (int a = 0; a < 3; ++a) request.mutable_settings()->set_shadow_map_size(a, 64);
  status = call(d.address()).render(request, &response);
  EXPECT_TRUE(status.ok()) << status.error_message();
}

// BuildVolume(keep) checks its model before it takes a --max-sessions slot: with the one slot taken, a bad
// model is INVALID_ARGUMENT (naming its field), not RESOURCE_EXHAUSTED, which a client would retry.
TEST(CloudsService, ABadModelIsInvalidEvenWhenTheSessionsAreFull) {
  test::Daemon d({"--max-sessions", "1"});
  v1::BuildVolumeRequest request;
  *request.mutable_model() = sphere_model();
  request.set_keep(true);
  v1::BuildVolumeResponse built;
  ASSERT_TRUE(call(d.address()).build(request, &built).ok());
  grpc::Status status = call(d.address()).build(request, &built);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
  request.mutable_model()->set_voxel_size(0);
  status = call(d.address()).build(request, &built);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
  EXPECT_NE(status.error_message().find("model.voxel_size"), std::string::npos) << status.error_message();
}

// A build counts in --memory-budget before it starts: a 22 m sphere in 10 cm voxels (its band and leaves
// grow it to about 5.4e7 voxels, 16 bytes each at the build's peak) is refused under a budget of 512 MiB at
// once, and a 5 m one (1.2e6 voxels) is built; so is a mesh's reading.
TEST(CloudsService, ABuildPastTheMemoryBudgetIsRefusedBeforeItStarts) {
  test::Daemon d({"--memory-budget", std::to_string(512ull << 20)});
  v1::BuildVolumeRequest request;
  v1::CloudModel& model = *request.mutable_model();
  model.set_voxel_size(0.1);
  model.set_skin(0.2);
  model.add_spheres()->set_radius(22);
  v1::BuildVolumeResponse built;
  const auto start = std::chrono::steady_clock::now();
  grpc::Status status = call(d.address()).build(request, &built);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
  EXPECT_NE(status.error_message().find("BuildVolume's build"), std::string::npos) << status.error_message();
  EXPECT_LT(seconds_since(start), 1.0);
  model.mutable_spheres(0)->set_radius(5);
  status = call(d.address()).build(request, &built);
  EXPECT_TRUE(status.ok()) << status.error_message();
  // Reading a mesh counts too, before it is read: 4e6 vertices in 32 MB of OBJ text take 768 MB to read
  // and check (192 bytes each), refused at once.
  std::string obj;
  for (int k = 0; k < 4000000; ++k) obj += "v 0 0 0\n";
  model.add_meshes()->set_obj(obj);
  status = call(d.address()).build(request, &built);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
  EXPECT_NE(status.error_message().find("BuildVolume's meshes, read"), std::string::npos) << status.error_message();
}

// squalld's resident memory (VmRSS, or VmHWM: its peak since reset_peak), bytes.
uint64_t resident_bytes(pid_t pid, const std::string& key) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(status, line);)
    if (line.starts_with(key + ":")) return std::stoull(line.substr(key.size() + 1)) * 1024;  // "NNN kB"
  ADD_FAILURE() << "no " << key << " in /proc/" << pid << "/status";
  return 0;
}
// Resets squalld's VmHWM to its VmRSS (proc(5), clear_refs "5"); false where the kernel does not.
bool reset_peak(pid_t pid) {
  std::ofstream clear("/proc/" + std::to_string(pid) + "/clear_refs");
  clear << "5" << std::flush;
  return clear.good() && resident_bytes(pid, "VmHWM") <= resident_bytes(pid, "VmRSS") + (4 << 20);
}

// A unit 3-vector pointing to the k-th of n points spread over the sphere (a Fibonacci lattice).
std::array<double, 3> direction(int k, int n) {
  const double z = 1 - (2 * k + 1.0) / n, rho = std::sqrt(1 - z * z), phi = k * M_PI * (3 - std::sqrt(5.0));
  return {rho * std::cos(phi), rho * std::sin(phi), z};
}

// `count` regular tetrahedra of edge sqrt(2) m on a cubic lattice of pitch `pitch` m, as one mesh.
v1::MeshSpec tetrahedra(int count, double pitch) {
  v1::MeshSpec mesh;
  const int side = int(std::ceil(std::cbrt(count)));
  for (int n = 0; n < count; ++n) {
    const double x = pitch * (n % side), y = pitch * (n / side % side), z = pitch * (n / side / side);
    for (const auto& [a, b, c] : {std::array{0.5, 0.5, 0.5}, {0.5, -0.5, -0.5}, {-0.5, 0.5, -0.5}, {-0.5, -0.5, 0.5}})
      for (double v : {x + a, y + b, z + c}) mesh.add_vertices(v);
    for (uint32_t k : {0u, 1u, 2u, 0u, 3u, 1u, 0u, 2u, 3u, 1u, 3u, 2u}) mesh.add_triangles(4 * n + k);
  }
  return mesh;
}

// `count` needles `length` m long from one shared vertex at the origin: one piece, far from convex.
v1::MeshSpec star(int count, double length) {
  v1::MeshSpec mesh;
  for (double v : {0.0, 0.0, 0.0}) mesh.add_vertices(v);
  for (int n = 0; n < count; ++n) {
    const auto d = direction(n, count), u = direction((n + count / 2) % count, count);
    const std::array<double, 3> side = {d[1] * u[2] - d[2] * u[1], d[2] * u[0] - d[0] * u[2],
                                        d[0] * u[1] - d[1] * u[0]};
    const double norm = std::hypot(side[0], side[1], side[2]);
    for (int a = 0; a < 3; ++a) mesh.add_vertices(length * d[a]);
    for (int a = 0; a < 3; ++a) mesh.add_vertices(0.5 * d[a] + 0.3 * side[a] / norm);
    for (int a = 0; a < 3; ++a) mesh.add_vertices(0.5 * d[a] + 0.3 * u[a]);
    const uint32_t tip = 1 + 3 * n, b = tip + 1, c = tip + 2;
    for (uint32_t k : {0u, b, c, 0u, tip, b, 0u, c, tip, tip, c, b}) mesh.add_triangles(k);
  }
  return mesh;
}

// A build is charged what it holds at its peak before it starts. Shapes whose bands dwarf their volumes,
// measured as squalld's peak resident memory over the build, stay within their charge: a thousand
// tetrahedra 200 m apart (each band a ball of whole OpenVDB leaves), 125 of them 5 km apart (each in
// internal nodes of its own), a flat ellipsoid with a temperature field (all band), and a star of needles
// (not convex: its whole grown box); the convex ones above an eighth of it. The thousand tetrahedra in a
// band of 20 m (about 2 GB of grids, an estimated 1.7e5 active voxels) are refused under a budget of 2 GiB
// before anything is built.
TEST(CloudsService, ABuildStaysWithinWhatTheMemoryBudgetChargedIt) {
#if defined(__has_feature)
#if __has_feature(address_sanitizer)
  GTEST_SKIP() << "AddressSanitizer's shadow memory and quarantine count in squalld's resident memory";
#endif
#endif
  const std::vector<std::string> flags = {"--memory-budget", std::to_string(2ull << 30)};
  struct Case {
    const char* name;
    v1::CloudModel model;
    bool convex;
  };
  std::vector<Case> cases(4);
  for (Case& c : cases) {
    c.model.set_voxel_size(1);
    c.model.set_skin(2);
    c.convex = true;
  }
  cases[0].name = "1000 tetrahedra 200 m apart";
  *cases[0].model.add_meshes() = tetrahedra(1000, 200);
  cases[1].name = "125 tetrahedra 5 km apart";
  *cases[1].model.add_meshes() = tetrahedra(125, 5000);
  cases[2].name = "a flat ellipsoid with a temperature field";
  auto* radii = cases[2].model.add_ellipsoids()->mutable_radii();
  radii->set_x(400);
  radii->set_y(400);
  radii->set_z(1);
  cases[2].model.mutable_temperature()->set_enabled(true);
  cases[3].name = "a star of 60 needles 150 m long";
  *cases[3].model.add_meshes() = star(60, 150);
  cases[3].convex = false;
  for (const Case& c : cases) {
    test::Daemon d(flags);  // a fresh one: no memory freed by an earlier build to take the next one's place
    const pid_t pid = d.process().pid();
    const uint64_t charged = clouds::build_bytes(clouds::rpc::model(c.model));
    v1::BuildVolumeRequest request;
    *request.mutable_model() = c.model;
    v1::BuildVolumeResponse built;
    const uint64_t before = resident_bytes(pid, "VmRSS");
    if (!reset_peak(pid)) GTEST_SKIP() << "this kernel does not reset a process's peak resident memory";
    const grpc::Status status = call(d.address()).build(request, &built);
    ASSERT_TRUE(status.ok()) << c.name << ": " << status.error_message();
    const uint64_t peak = std::max(resident_bytes(pid, "VmHWM"), before) - before;
    std::printf("%s: build's peak %.0f MB, charged %.0f MB\n", c.name, peak / 1e6, charged / 1e6);
    EXPECT_LE(peak, charged) << c.name;
    if (c.convex) {
      EXPECT_GE(peak, charged / 8) << c.name << ": a charge far above the peak holds back other calls";
    }
  }
  test::Daemon d(flags);
  v1::BuildVolumeRequest request;
  *request.mutable_model() = cases[0].model;
  request.mutable_model()->set_skin(20);
  v1::BuildVolumeResponse built;
  const auto start = std::chrono::steady_clock::now();
  const grpc::Status status = call(d.address()).build(request, &built);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
  EXPECT_NE(status.error_message().find("BuildVolume's build"), std::string::npos) << status.error_message();
  EXPECT_LT(seconds_since(start), 1.0);
}

// A sphere of 5 m in 5 cm voxels (about 7e6) advected in 256 MacCormack substeps: 4e9 velocity samples,
// past --max-advection-samples = 1e9: refused before the build starts, naming the substeps.
TEST(CloudsService, ABuildWhoseAdvectionIsTooCostlyIsRefused) {
  v1::BuildVolumeResponse built;
  const auto start = std::chrono::steady_clock::now();
  const grpc::Status status = call().build(advected_build(test::long_work_sphere(), 0.05), &built);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
  EXPECT_NE(status.error_message().find("model.advection.substeps = 256 makes an estimated"), std::string::npos)
      << status.error_message();
  EXPECT_NE(status.error_message().find("--max-advection-samples"), std::string::npos) << status.error_message();
  EXPECT_LT(seconds_since(start), 1.0);
}

// `squall cloud build -o x.vdb` writes a file that OpenVDB's vdb_print lists; `squall cloud render` an EXR
// (and PNG preview); bad flags exit 2, a refused request 4.
TEST(CloudsCli, BuildWritesVdbAndRenderWritesExr) {
  std::string dir = test::temp_dir("clouds-cli");
  std::string out;
  std::vector<std::string> base = {kSquall, "--address", daemon().address(), "cloud"};
  auto args = [&](std::vector<std::string> rest) {
    std::vector<std::string> a = base;
    a.insert(a.end(), rest.begin(), rest.end());
    return a;
  };
  ASSERT_EQ(test::run(args({"build", "--voxel-size", "0.5", "--sphere", "0,0,0,4", "--pyro", "1,1,0.3", "--temperature",
                            "280,0.0065", "-o", dir + "/c.vdb"}),
                      &out),
            0)
      << out;
  EXPECT_NE(out.find("active voxels"), std::string::npos) << out;
  std::string listing;
  ASSERT_EQ(test::run({"/usr/bin/vdb_print", dir + "/c.vdb"}, &listing), 0) << listing;  // execv: full path
  EXPECT_NE(listing.find("density"), std::string::npos) << listing;
  EXPECT_NE(listing.find("temperature"), std::string::npos) << listing;
  ASSERT_EQ(
      test::run(args({"render", "--voxel-size", "0.5", "--sphere", "0,0,0,4", "--eye", "0,-30,0", "--size", "32x24",
                      "--step", "0.25", "--sun", "0,0,1,1000", "--extinction", "0.5", "-o", dir + "/c.exr"}),
                &out),
      0)
      << out;
  EXPECT_TRUE(std::filesystem::exists(dir + "/c.exr"));
  EXPECT_TRUE(std::filesystem::exists(dir + "/c.png"));
  // The preview goes beside the output whatever its name: "my.dir/cloud" gives my.dir/cloud.png.
  std::filesystem::create_directories(dir + "/my.dir");
  ASSERT_EQ(test::run(args({"render", "--voxel-size", "0.5", "--sphere", "0,0,0,4", "--eye", "0,-30,0", "--size", "8x8",
                            "-o", dir + "/my.dir/cloud"}),
                      &out),
            0)
      << out;
  EXPECT_TRUE(std::filesystem::exists(dir + "/my.dir/cloud.png"));
  if (std::filesystem::exists("/dev/full")) {  // written in full or exit 5
    EXPECT_EQ(test::run(args({"build", "--voxel-size", "0.5", "--sphere", "0,0,0,1", "-o", "/dev/full"}), &out), 5)
        << out;
  }
  EXPECT_EQ(test::run(args({"render", "--sphere", "0,0,0", "-o", dir + "/x.exr"}), &out), 2) << out;
  // The files are EXR and VDB whatever -o says: another extension is refused before anything runs.
  EXPECT_EQ(test::run(args({"render", "--sphere", "0,0,0,4", "-o", dir + "/x.png"}), &out), 2) << out;
  EXPECT_NE(out.find("x.png: the file is written as OpenEXR"), std::string::npos) << out;
  EXPECT_EQ(test::run(args({"build", "--sphere", "0,0,0,4", "-o", dir + "/z.EXR"}), &out), 2) << out;
  EXPECT_NE(out.find("z.EXR: the file is written as an OpenVDB grid file, so its name ends in .vdb"), std::string::npos)
      << out;
  // The last --extinction given is the one sent: here a negative one, which the server refuses.
  EXPECT_EQ(test::run(args({"render", "--sphere", "0,0,0,4", "--size", "8x8", "--extinction", "0.5", "--extinction",
                            "-1", "-o", dir + "/x.exr"}),
                      &out),
            4)
      << out;
  EXPECT_NE(out.find("extinction"), std::string::npos) << out;
  EXPECT_EQ(test::run(args({"render", "--sphere", "0,0,0,4", "--size", "8x8", "--min-transmittance", "0.041", "-o",
                            dir + "/t.exr"}),
                      &out),
            0)
      << out;
  EXPECT_EQ(test::run(args({"render", "--sphere", "0,0,0,4", "--size", "8x8", "--min-transmittance", "1", "-o",
                            dir + "/x.exr"}),
                      &out),
            4)
      << out;
  EXPECT_NE(out.find("settings.min_transmittance"), std::string::npos) << out;
  EXPECT_EQ(test::run(args({"render", "--volume", "cloud-404", "-o", dir + "/x.exr"}), &out), 4) << out;
  EXPECT_NE(out.find("NOT_FOUND"), std::string::npos) << out;
}

// The channels `names` of the w x h EXR at `path`, read with OpenEXR's own InputFile, one after another.
std::vector<float> exr_channels(const std::string& path, const std::vector<std::string>& names, int w, int h) {
  Imf::InputFile file(path.c_str());
  std::vector<float> pixels(names.size() * w * h);
  Imf::FrameBuffer frame;
  for (size_t c = 0; c < names.size(); ++c) {
    EXPECT_NE(file.header().channels().findChannel(names[c]), nullptr) << names[c];
    frame.insert(names[c], Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(&pixels[c * w * h]), 4, 4 * w));
  }
  file.setFrameBuffer(frame);
  file.readPixels(0, h - 1);
  return pixels;
}

// `--lamp X,Y,Z,I` is a point light of intensity I at every wavelength, at X,Y,Z: a lamp inside the cloud, the
// only light, lights it (every pixel finite, the brightest nearest the lamp), both wavelengths alike (one
// extinction and albedo for all), and twice the intensity gives twice the radiance, bit for bit. Its PNG
// preview shows the cloud lit around the lamp.
TEST(CloudsCli, ALampLightsTheCloudInProportionToItsIntensity) {
  const std::string dir = test::temp_dir("clouds-cli-lamp");
  std::string out;
  auto render = [&](const std::string& intensity, const std::string& file, const std::string& preview) {
    EXPECT_EQ(test::run({kSquall,         "--address", daemon().address(),
                         "cloud",         "render",    "--voxel-size",
                         "0.5",           "--sphere",  "0,0,0,4",
                         "--eye",         "0,-30,0",   "--size",
                         "16x12",         "--step",    "0.25",
                         "--shadow",      "direct",    "--wavelengths",
                         "450e-9,650e-9", "--lamp",    "0.3,-0.2,0.1," + intensity,
                         "--preview",     preview,     "-o",
                         dir + "/" + file},
                        &out),
              0)
        << out;
    return exr_channels(dir + "/" + file, {"radiance_0", "radiance_1"}, 16, 12);
  };
  const std::vector<float> once = render("1000", "once.exr", dir + "/once.png");
  const std::vector<float> twice = render("2000", "twice.exr", "none");
  const size_t plane = 16 * 12;
  double sum = 0;
  for (size_t i = 0; i < plane; ++i) {
    ASSERT_TRUE(std::isfinite(once[i])) << i;
    EXPECT_EQ(once[plane + i], once[i]) << i;
    sum += once[i];
  }
  EXPECT_GT(sum, 0.0);
  // The brightest pixel is the one whose ray passes nearest the lamp, 0.3 m right of and 0.1 m above the view
  // axis: (8, 5), whose ray passes 1.0 m from it (pixels are 1.8 m wide there).
  EXPECT_EQ(std::max_element(once.begin(), once.begin() + plane) - once.begin(), 5 * 16 + 8);
  for (size_t i = 0; i < once.size(); ++i) EXPECT_EQ(twice[i], 2 * once[i]) << i;
  // The preview shows most of the cloud lit around the lamp (its radiance exposed at the 99th percentile of
  // the lit pixels and sRGB-encoded: 12 of 16 above a tenth of white), not only the pixels next to it, as a
  // preview spanning min..max linearly did (4 of 16).
  const test::GreyImage preview = test::read_png_grey(dir + "/once.png");
  ASSERT_EQ(preview.pixels.size(), plane);
  EXPECT_EQ(preview.pixels[5 * 16 + 8], 255);
  const auto lit = std::count_if(preview.pixels.begin(), preview.pixels.end(), [](png_byte g) { return g >= 26; });
  const std::vector<float> radiance(once.begin(), once.begin() + plane);
  const auto covered = std::count_if(radiance.begin(), radiance.end(), [](float l) { return l > 0; });
  EXPECT_GE(lit, 0.7 * double(covered)) << "pixels above a tenth of white, of " << covered << " the cloud covers";
  const std::vector<unsigned char> range = client::preview_grey(radiance, client::Tone::Range);
  EXPECT_GT(lit, 2 * std::count_if(range.begin(), range.end(), [](unsigned char g) { return g >= 26; }));
}

// Flag values that are not what they say exit 2 naming the value, before any call: a count that is negative,
// fractional or past its type, a size with more after WxH, a phase with no parameters, an unknown verb.
TEST(CloudsCli, BadFlagValuesAreRefusedNamingThem) {
  const std::string dir = test::temp_dir("clouds-cli-flags");
  const std::vector<std::string> model = {"--voxel-size", "0.5", "--sphere", "0,0,0,4", "-o", dir + "/x.exr"};
  const std::pair<std::vector<std::string>, std::string> cases[] = {
      {{"build", "--max-voxels", "-5"}, "--max-voxels -5: must be an integer >= 1"},
      {{"build", "--max-voxels", "99999999999999999999999"}, "--max-voxels 99999999999999999999999: must be"},
      {{"build", "--pyro", "-1,1,0.3"}, "--pyro -1,1,0.3: -1 is no count"},
      {{"build", "--advect", "1,2,2.5"}, "--advect 1,2,2.5: 2.5 is no count"},
      {{"render", "--size", "8x8x8"}, "--size 8x8x8: must be WxH, two integers >= 1"},
      {{"render", "--size", "8x4294967296"}, "--size 8x4294967296: must be WxH"},
      {{"render", "--phase", "hg"}, "--phase hg: uniform, hg:G, dhg:G1,G2,W or ff:N,MU"},
      {{"render", "--phase", "hg:0.5,0.3"}, "--phase hg:0.5,0.3: uniform, hg:G, dhg:G1,G2,W or ff:N,MU"},
      {{"render", "--phase", "uniform:anything"}, "--phase uniform:anything: uniform, hg:G"},
      {{"render", "--step", "1,2"}, "--step 1,2: needs 1 number"},
      {{"render", "--lamp", "0,0,0"}, "--lamp 0,0,0: needs 4 numbers"},
      {{"render", "--min-transmittance", "0.1,0.2"}, "--min-transmittance 0.1,0.2: needs 1 number"},
      {{"render", "--shadow", "none", "--shadow-step", "5"}, "not flags of --shadow none"},
      {{"render", "--shadow-trilinear", "--shadow", "none"}, "not flags of --shadow none"},
      {{"frobnicate"}, "unknown cloud verb frobnicate (build or render)"},
      // flags the verb would ignore, and squall's own after the verb
      {{"build", "--eye", "0,1,0"}, "--eye is not a flag of `squall cloud build`"},
      {{"build", "--preview", "none"}, "--preview is not a flag of `squall cloud build`"},
      {{"render", "--keep"}, "--keep is not a flag of `squall cloud render`"},
      {{"render", "--volume", "cloud-1"}, "--voxel-size: `cloud render --volume ID` renders the stored volume"},
      {{"render", "--address", "127.0.0.1:2"}, "--address is a flag of squall itself"},
      {{"build", "--mesh", "/tmp"}, "--mesh /tmp: cannot read it"},
      {{"build", "--ellipsoid", "0,0,0,1,1,1,"}, "--ellipsoid 0,0,0,1,1,1,: an empty item in the list"},
      {{"build", "--ellipsoid", "0,0,0,1,0x1,1"}, "--ellipsoid 0,0,0,1,0x1,1: 0x1 is not a finite number"},
      {{"render", "--preview", dir + "/./x.exr"}, "is the file -o names"},
  };
  for (const auto& [flags, message] : cases) {
    std::vector<std::string> args = {kSquall, "--address", "127.0.0.1:1", "cloud"};
    args.insert(args.end(), flags.begin(), flags.end());
    args.insert(args.end(), model.begin(), model.end());
    std::string out;
    EXPECT_EQ(test::run(args, &out), 2) << flags.back() << ": " << out;
    EXPECT_NE(out.find(message), std::string::npos) << out;
  }
}

}  // namespace
}  // namespace squall
