// squall.v1.Textures through a real squalld: frames of each method equal to an in-process TextureEngine
// run bit for bit, checkpoints that resume a stream bit-identically, the documented errors, and the
// `squall texture advect` command line.
#include <gtest/gtest.h>
#include <png.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>

#include "client/client.h"
#include "client/image_io.h"
#include "common/field_codec.h"
#include "squall/v1/textures.grpc.pb.h"
#include "support/daemon.h"
#include "support/expect_error.h"
#include "support/test_runtime.h"
#include "textures/texture_engine.h"
#include "textures/textures_request.h"
#include "service_support.h"

namespace squall {
namespace {

namespace v1 = squall::v1;
using namespace squall::textures_test;
constexpr double kPi = 3.14159265358979323846;

// The same request run by the in-process engine, frame by frame until frame `frames - 1`.
std::vector<textures::TextureFrame> in_process(const v1::AdvectTextureRequest& request) {
  textures::AdvectSpec spec = translated(request);
  engine().validate(spec, "request");
  auto advection = engine().start(spec);
  std::vector<textures::TextureFrame> frames;
  for (int i = 0; i < spec.frames; ++i) frames.push_back(advection->next());
  return frames;
}

// A 32 x 32 two-channel image (smooth, tileable) advected by a Taylor-Green flow over a 48 x 40 output.
v1::AdvectTextureRequest image_request(v1::TextureMethod method) {
  v1::AdvectTextureRequest r;
  r.set_method(method);
  auto* v = r.mutable_velocity()->mutable_named();
  v->set_kind(v1::AnalyticVelocity::KIND_TAYLOR_GREEN);
  v->set_speed(0.3);
  v->set_period(1);
  std::vector<float> a(32 * 32), b(32 * 32);
  for (int j = 0; j < 32; ++j) {
    for (int i = 0; i < 32; ++i) {
      a[i + 32 * j] = float(0.5 + 0.5 * std::sin(2 * kPi * i / 32) * std::cos(2 * kPi * j / 32));
      b[i + 32 * j] = float(0.5 + 0.5 * std::cos(2 * kPi * (i + 2 * j) / 32));
    }
  }
  auto* image = r.mutable_texture()->mutable_image();
  *image->add_channels() = float_field("a", 32, 32, a);
  *image->add_channels() = float_field("b", 32, 32, b);
  image->set_tileable(true);
  r.mutable_texture()->set_scale(2);
  r.mutable_output()->set_width(48);
  r.mutable_output()->set_height(40);
  r.mutable_eulerian()->set_grid_nx(24);
  r.mutable_eulerian()->set_grid_ny(20);
  r.set_t0(1.0);
  r.set_dt(0.1);
  r.set_frames(3);
  all_planes(r);
  return r;
}

// A streamed frame equals the engine's: the same planes, byte for byte, and the same statistics.
void expect_same(const v1::TextureFrame& got, const textures::TextureFrame& want) {
  ASSERT_EQ(got.index(), uint32_t(want.index));
  EXPECT_EQ(got.time(), want.time);
  const int planes = want.final_planes + want.raw_planes + SQUALL_AUX_PLANES;
  ASSERT_EQ(got.planes_size(), planes);
  const size_t n = size_t(want.width) * want.height;
  for (int k = 0; k < planes; ++k) {
    const std::string& bytes = got.planes(k).data();
    ASSERT_EQ(bytes.size(), n * sizeof(float)) << got.planes(k).name();
    EXPECT_EQ(std::memcmp(bytes.data(), want.plane(k), bytes.size()), 0) << "plane " << got.planes(k).name();
  }
  ASSERT_EQ(got.stats().mean_size(), int(want.stats.mean.size()));
  for (size_t c = 0; c < want.stats.mean.size(); ++c) {
    EXPECT_EQ(got.stats().mean(int(c)), want.stats.mean[c]);
    EXPECT_EQ(got.stats().stddev(int(c)), want.stats.stddev[c]);
  }
  EXPECT_EQ(got.stats().uncovered_pixels(), want.stats.uncovered);
}

// Indices 0.., times t0 + i dt, planes of the output's size placed on its pixels, finite values, stats.
void expect_well_formed(const Streamed& s, const v1::AdvectTextureRequest& r) {
  ASSERT_TRUE(s.status.ok()) << s.status.error_message();
  ASSERT_EQ(s.frames.size(), size_t(r.frames()));
  const uint32_t w = r.output().width(), h = r.output().height();
  for (size_t i = 0; i < s.frames.size(); ++i) {
    const v1::TextureFrame& f = s.frames[i];
    EXPECT_EQ(f.index(), uint32_t(i));
    EXPECT_NEAR(f.time(), r.t0() + double(i) * r.dt(), 1e-12);
    ASSERT_GT(f.planes_size(), 0);
    EXPECT_TRUE(f.planes(0).name() == "final" || f.planes(0).name() == "final_0") << f.planes(0).name();
    for (const auto& p : f.planes()) {
      EXPECT_EQ(p.nx(), w);
      EXPECT_EQ(p.ny(), h);
      EXPECT_DOUBLE_EQ(p.spacing().x(), 1.0 / w);
      EXPECT_DOUBLE_EQ(p.origin().y(), 0.5 / h);
      for (float v : field::decode(p, p.name())) ASSERT_TRUE(std::isfinite(v)) << p.name();
    }
    EXPECT_GT(f.stats().mean_size(), 0);
    EXPECT_EQ(f.stats().mean_size(), f.stats().stddev_size());
    EXPECT_GT(f.stats().stages_size(), 0);
    EXPECT_TRUE(f.checkpoint().empty());
  }
}

TEST(TexturesService, LagrangianNoiseMatchesTheEngine) {
  v1::AdvectTextureRequest r = noise_request(3);
  Streamed s = advect(r);
  expect_well_formed(s, r);
  ASSERT_EQ(s.frames.size(), 3u);
  EXPECT_EQ(s.frames[0].planes_size(), 1 + 3 + 6);  // SUM_BANDS: one final plane, 3 raw bands, 6 auxiliary
  EXPECT_GT(s.frames[2].stats().particles().alive(), 0);
  EXPECT_NE(s.frames[0].planes(0).data(), s.frames[2].planes(0).data());  // the texture moved
  auto want = in_process(r);
  for (size_t i = 0; i < want.size(); ++i) expect_same(s.frames[i], want[i]);
}

TEST(TexturesService, ImageThroughEachEulerianMethodMatchesTheEngine) {
  for (auto method :
       {v1::TEXTURE_METHOD_EULERIAN_MULTILAYER, v1::TEXTURE_METHOD_TWO_PHASE_FLOW_MAP, v1::TEXTURE_METHOD_NAIVE}) {
    SCOPED_TRACE(v1::TextureMethod_Name(method));
    v1::AdvectTextureRequest r = image_request(method);
    Streamed s = advect(r);
    expect_well_formed(s, r);
    ASSERT_EQ(s.frames.size(), 3u);
    EXPECT_EQ(s.frames[0].planes(1).name(), "final_1");  // IDENTITY of two channels
    EXPECT_EQ(s.frames[0].planes(2).name(), "raw_0");
    EXPECT_NE(s.frames[0].planes(0).data(), s.frames[2].planes(0).data());  // the texture moved
    auto want = in_process(r);
    for (size_t i = 0; i < want.size(); ++i) expect_same(s.frames[i], want[i]);
  }
}

// checkpoint_every = 2 puts the state on frames 0, 2, 4; resuming from frame 2's sends frames 3 and 4,
// bit-identical to the first stream's.
// Every method streams both kinds of texture: noise and a two-channel image, each frame equal to the
// in-process engine's.
TEST(TexturesService, NoiseAndImageThroughEveryMethodMatchTheEngine) {
  for (auto method : {v1::TEXTURE_METHOD_LAGRANGIAN_GRIDS, v1::TEXTURE_METHOD_EULERIAN_MULTILAYER,
                      v1::TEXTURE_METHOD_TWO_PHASE_FLOW_MAP, v1::TEXTURE_METHOD_NAIVE}) {
    SCOPED_TRACE(v1::TextureMethod_Name(method));
    v1::AdvectTextureRequest noise = noise_request(2);
    noise.set_method(method);
    for (const v1::AdvectTextureRequest& r : {noise, image_request(method)}) {
      Streamed s = advect(r);
      expect_well_formed(s, r);
      auto want = in_process(r);
      ASSERT_EQ(s.frames.size(), want.size());
      for (size_t i = 0; i < want.size(); ++i) expect_same(s.frames[i], want[i]);
    }
  }
}

TEST(TexturesService, CheckpointResumesBitIdentically) {
  for (auto method : {v1::TEXTURE_METHOD_LAGRANGIAN_GRIDS, v1::TEXTURE_METHOD_EULERIAN_MULTILAYER}) {
    SCOPED_TRACE(v1::TextureMethod_Name(method));
    v1::AdvectTextureRequest r = noise_request(5);
    r.set_method(method);
    r.set_checkpoint_every(2);
    Streamed first = advect(r);
    ASSERT_TRUE(first.status.ok()) << first.status.error_message();
    ASSERT_EQ(first.frames.size(), 5u);
    for (size_t i = 0; i < 5; ++i) EXPECT_EQ(first.frames[i].checkpoint().empty(), i % 2 == 1) << "frame " << i;
    r.set_checkpoint_every(0);
    r.set_frames(6);  // the same request but for its length: frames 3 and 4 as before, then one more
    r.set_resume_state(first.frames[2].checkpoint());
    Streamed resumed = advect(r);
    ASSERT_TRUE(resumed.status.ok()) << resumed.status.error_message();
    ASSERT_EQ(resumed.frames.size(), 3u);
    EXPECT_EQ(resumed.frames[2].index(), 5);
    for (size_t k = 0; k < 2; ++k) {
      const v1::TextureFrame &a = resumed.frames[k], &b = first.frames[3 + k];
      EXPECT_EQ(a.index(), b.index());
      EXPECT_EQ(a.time(), b.time());
      ASSERT_EQ(a.planes_size(), b.planes_size());
      for (int p = 0; p < a.planes_size(); ++p) EXPECT_EQ(a.planes(p).data(), b.planes(p).data()) << a.planes(p).name();
    }
    r.set_frames(5);
    r.set_resume_state(first.frames[4].checkpoint());  // the last frame: nothing left to send
    test::expect_error(Code::InvalidArgument, "leaves no frame after it", [&] { advect_or_throw(r); });
  }
}

// A checkpoint continues only the request that made it: resumed with another dt, seed or method it is
// refused, not continued as if it were theirs; cut short, even to its fingerprint, it is no checkpoint.
TEST(TexturesService, CheckpointOfAnotherRequestIsRefused) {
  v1::AdvectTextureRequest r = noise_request(3);
  r.set_method(v1::TEXTURE_METHOD_EULERIAN_MULTILAYER);
  r.set_checkpoint_every(1);
  Streamed first = advect(r);
  ASSERT_TRUE(first.status.ok()) << first.status.error_message();
  ASSERT_EQ(first.frames.size(), 3u);
  r.set_checkpoint_every(0);
  r.set_resume_state(first.frames[1].checkpoint());
  const std::vector<std::function<void(v1::AdvectTextureRequest&)>> changes = {
      [](v1::AdvectTextureRequest& q) { q.set_dt(2 * q.dt()); },
      [](v1::AdvectTextureRequest& q) { q.set_seed(q.seed() + 1); },
      [](v1::AdvectTextureRequest& q) { q.set_method(v1::TEXTURE_METHOD_TWO_PHASE_FLOW_MAP); },
  };
  for (size_t c = 0; c < changes.size(); ++c) {
    SCOPED_TRACE("change " + std::to_string(c));
    v1::AdvectTextureRequest other = r;
    changes[c](other);
    test::expect_error(Code::InvalidArgument, "request.resume_state is the checkpoint of another request",
                       [&] { advect_or_throw(other); });
  }
  const std::string& checkpoint = first.frames[1].checkpoint();
  // Any one bit of the state flipped (here in the frame index, then further in) is found by the checksum.
  for (size_t byte : {size_t(24 + 5), size_t(24 + 40), checkpoint.size() - 1}) {
    v1::AdvectTextureRequest flipped = r;
    std::string damaged = checkpoint;
    damaged[byte] = char(damaged[byte] ^ 0x04);
    flipped.set_resume_state(damaged);
    test::expect_error(Code::InvalidArgument, "request.resume_state is damaged: its state does not match",
                       [&] { advect_or_throw(flipped); });
  }
  for (size_t cut : {size_t(3), size_t(16), size_t(24)}) {  // inside the magic; no checksum; no state
    v1::AdvectTextureRequest truncated = r;
    truncated.set_resume_state(checkpoint.substr(0, cut));
    test::expect_error(Code::InvalidArgument, "request.resume_state is not a texture checkpoint",
                       [&] { advect_or_throw(truncated); });
  }
  Streamed same = advect(r);
  ASSERT_TRUE(same.status.ok()) << same.status.error_message();
  ASSERT_EQ(same.frames.size(), 1u);
  EXPECT_EQ(same.frames[0].planes(0).data(), first.frames[2].planes(0).data());
}

// A 5 x 5 two-frame velocity grid with a solid node (push-pull), and a PNG image: float16 planes.
v1::AdvectTextureRequest grid_png_request(const std::string& dir) {
  v1::AdvectTextureRequest r;
  r.set_method(v1::TEXTURE_METHOD_NAIVE);
  auto* g = r.mutable_velocity()->mutable_grid();
  g->set_nx(5);
  g->set_ny(5);
  g->mutable_spacing()->set_x(0.25);
  g->mutable_spacing()->set_y(0.25);
  for (double t : {0.0, 1.0}) {
    auto* frame = g->add_frames();
    frame->set_time(t);
    std::vector<float> u(25, float(0.2 + 0.1 * t)), v(25);
    for (int k = 0; k < 25; ++k) v[k] = float(0.1 * (k % 5) * 0.25);
    *frame->mutable_u() = float_field("u", 5, 5, u);
    *frame->mutable_v() = float_field("v", 5, 5, v);
  }
  std::vector<float> mask(25, 1);
  mask[12] = 0;
  *g->mutable_mask() = float_field("mask", 5, 5, mask);
  g->set_extrapolation(v1::VelocityGrid::EXTRAPOLATION_PUSH_PULL);
  std::vector<float> ramp(16 * 8);
  for (size_t k = 0; k < ramp.size(); ++k) ramp[k] = float((k * 37) % 101);
  client::write_png_preview(dir + "/texture.png", 16, 8, ramp);
  r.mutable_texture()->mutable_image()->set_png(test::read_file(dir + "/texture.png"));
  r.mutable_output()->set_width(24);
  r.mutable_output()->set_height(24);
  r.mutable_output()->set_dtype(v1::DTYPE_FLOAT16);
  r.set_frames(2);
  return r;
}

TEST(TexturesService, GridVelocityAndPngImage) {
  v1::AdvectTextureRequest r = grid_png_request(test::temp_dir("textures-png"));
  Streamed s = advect(r);
  ASSERT_TRUE(s.status.ok()) << s.status.error_message();
  ASSERT_EQ(s.frames.size(), 2u);
  const v1::Field& f = s.frames[1].planes(0);
  EXPECT_EQ(f.name(), "final");  // a grey PNG: one channel
  EXPECT_EQ(f.dtype(), v1::DTYPE_FLOAT16);
  EXPECT_EQ(f.data().size(), 24u * 24 * 2);
  const std::vector<float> values = field::decode(f, "final");
  for (float v : values) {
    ASSERT_TRUE(std::isfinite(v));
    EXPECT_GE(v, -1e-3);  // PNG values are in [0, 1]; naive advection only moves them
    EXPECT_LE(v, 1 + 1e-3);
  }
  EXPECT_GT(*std::max_element(values.begin(), values.end()) - *std::min_element(values.begin(), values.end()), 0.5);
}

// A PNG's samples become channels in [0, 1]: 16-bit RGB and 8-bit grey + alpha, row j as texture row j.
TEST(TexturesRequest, PngSamplesBecomeUnitChannels) {
  const uint32_t w = 3, h = 2;
  std::vector<uint16_t> rgb16(w * h * 3);
  std::vector<uint8_t> ga8(w * h * 2);
  for (size_t k = 0; k < rgb16.size(); ++k) rgb16[k] = uint16_t(k * 3000 + 7);
  for (size_t k = 0; k < ga8.size(); ++k) ga8[k] = uint8_t(k * 20 + 1);
  struct Case {
    uint32_t format;
    const void* samples;
    int channels;
    std::function<float(size_t)> value;  // sample k of the file, scaled
  };
  const Case cases[] = {{PNG_FORMAT_LINEAR_RGB, rgb16.data(), 3, [&](size_t k) { return float(rgb16[k] / 65535.0); }},
                        {PNG_FORMAT_GA, ga8.data(), 2, [&](size_t k) { return float(ga8[k] / 255.0); }}};
  for (const Case& c : cases) {
    png_image image{};
    image.version = PNG_IMAGE_VERSION;
    image.width = w;
    image.height = h;
    image.format = c.format;
    png_alloc_size_t size = 0;
    ASSERT_TRUE(png_image_write_to_memory(&image, nullptr, &size, 0, c.samples, 0, nullptr));
    std::string bytes(size, '\0');
    ASSERT_TRUE(png_image_write_to_memory(&image, bytes.data(), &size, 0, c.samples, 0, nullptr));
    v1::AdvectTextureRequest r;
    r.mutable_texture()->mutable_image()->set_png(bytes);
    r.mutable_output()->set_width(1);
    r.mutable_output()->set_height(1);
    const textures::TextureSpec t = translated(r).texture;
    ASSERT_EQ(t.kind, SQUALL_TEXTURE_IMAGE);
    ASSERT_EQ(t.channels, c.channels);
    ASSERT_EQ(t.width, int(w));
    ASSERT_EQ(t.height, int(h));
    for (size_t pixel = 0; pixel < w * h; ++pixel)
      for (int ch = 0; ch < c.channels; ++ch)
        EXPECT_EQ(t.pixels[ch * w * h + pixel], c.value(pixel * c.channels + ch)) << pixel << " " << ch;
  }
}

// 8-bit interleaved pixels become planes of byte / 255; a wrong byte count, channel count or a second
// image source is refused naming the field.
TEST(TexturesRequest, EightBitPixelsBecomeUnitChannels) {
  const uint32_t w = 3, h = 2, channels = 3;
  std::string data(w * h * channels, '\0');
  for (size_t k = 0; k < data.size(); ++k) data[k] = char(uint8_t(k * 13 + 2));
  v1::AdvectTextureRequest r;
  auto* pixels = r.mutable_texture()->mutable_image()->mutable_pixels8();
  pixels->set_width(w);
  pixels->set_height(h);
  pixels->set_channels(channels);
  pixels->set_data(data);
  r.mutable_output()->set_width(1);
  r.mutable_output()->set_height(1);
  const textures::TextureSpec t = translated(r).texture;
  ASSERT_EQ(t.channels, int(channels));
  ASSERT_EQ(t.width, int(w));
  for (size_t pixel = 0; pixel < w * h; ++pixel)
    for (uint32_t c = 0; c < channels; ++c)
      EXPECT_EQ(t.pixels[c * w * h + pixel], float(uint8_t(data[pixel * channels + c])) / 255.0f);
  auto bad = r;
  bad.mutable_texture()->mutable_image()->mutable_pixels8()->set_data(data.substr(1));
  test::expect_error(Code::InvalidArgument, "request.texture.image.pixels8.data has 17 values, want",
                     [&] { translated(bad); });
  bad = r;
  bad.mutable_texture()->mutable_image()->mutable_pixels8()->set_channels(9);
  test::expect_error(Code::InvalidArgument, "request.texture.image.pixels8.channels = 9", [&] { translated(bad); });
  bad = r;
  bad.mutable_texture()->mutable_image()->set_png("x");
  test::expect_error(Code::InvalidArgument, "request.texture.image has 2 of channels, png and pixels8",
                     [&] { translated(bad); });
}

TEST(TexturesService, BadRequestsGetClearErrors) {
  struct Case {
    std::function<void(v1::AdvectTextureRequest&)> edit;
    Code code;
    std::string needle;
  };
  std::vector<Case> cases = {
      {[](v1::AdvectTextureRequest& r) {
         auto* v = r.mutable_velocity()->mutable_named();
         v->set_kind(v1::AnalyticVelocity::KIND_UNIFORM);
         v->set_velocity_x(NAN);
       },
       Code::InvalidArgument, "request.velocity.named.velocity_x = nan"},
      {[](v1::AdvectTextureRequest& r) {
         r.set_method(v1::TEXTURE_METHOD_NAIVE);
         *r.mutable_velocity()->mutable_grid() = grid_png_request(test::temp_dir("textures-bad")).velocity().grid();
         *r.mutable_velocity()->mutable_grid()->mutable_frames(1)->mutable_u() =
             float_field("u", 4, 5, std::vector<float>(20));
       },
       Code::InvalidArgument, "request.velocity.grid.frames[1].u.nx = 4"},
      {[](v1::AdvectTextureRequest& r) {  // the grid's size first, as sent, then its frames against it
         r.set_method(v1::TEXTURE_METHOD_NAIVE);
         *r.mutable_velocity()->mutable_grid() = grid_png_request(test::temp_dir("textures-bad")).velocity().grid();
         r.mutable_velocity()->mutable_grid()->set_nx(4294967295u);
       },
       Code::InvalidArgument, "request.velocity.grid.nx = 4294967295 must be in [2, 1048576]"},
      {[](v1::AdvectTextureRequest& r) { r.mutable_output()->set_width(0); }, Code::InvalidArgument,
       "request.output.width = 0"},
      {[](v1::AdvectTextureRequest& r) {
         r.mutable_output()->set_width(100000);
         r.mutable_output()->set_height(100000);
       },
       Code::ResourceExhausted, "request.output"},
      {[](v1::AdvectTextureRequest& r) {  // past an int as well: the cell limit, as sent
         r.mutable_output()->set_width((1u << 30) + 1);
         r.mutable_output()->set_height(1);
       },
       Code::ResourceExhausted, "request.output.width * request.output.height = 1073741825 cells"},
      {[](v1::AdvectTextureRequest& r) { r.set_resume_state("not a checkpoint at all"); }, Code::InvalidArgument,
       "resume_state"},
      {[](v1::AdvectTextureRequest& r) { r.mutable_texture()->mutable_image()->set_png("\x89PNG\r\n\x1a\n garbage"); },
       Code::InvalidArgument, "request.texture.image.png"},
      {[](v1::AdvectTextureRequest& r) { r.set_frames(0); }, Code::InvalidArgument, "request.frames = 0"},
      {[](v1::AdvectTextureRequest& r) { r.set_frames(4294967295u); }, Code::InvalidArgument,
       "request.frames = 4294967295 must be in [1, 100000]"},  // as sent, not capped
      {[](v1::AdvectTextureRequest& r) { r.set_substeps(4294967295u); }, Code::InvalidArgument,
       "request.substeps = 4294967295 must be in [1, 64]"},
      {[](v1::AdvectTextureRequest& r) { r.mutable_output()->mutable_region()->set_x0(2); }, Code::InvalidArgument,
       "request.output.region.x1 = 0 must be finite and > 2"},
      {[](v1::AdvectTextureRequest& r) { r.mutable_output()->set_dtype(v1::DType(9)); }, Code::InvalidArgument,
       "request.output.dtype"},
  };
  for (const auto& k : cases) {
    v1::AdvectTextureRequest r = noise_request(2);
    k.edit(r);
    test::expect_error(k.code, k.needle, [&] { advect_or_throw(r); });
  }
  ASSERT_TRUE(daemon().running());
  v1::AdvectTextureRequest good = noise_request(2);
  Streamed s = advect(good);
  expect_well_formed(s, good);
}

// An advection's state counts in --memory-budget beside its frames: 6 layers of 3 phases on 2048 x 2048 nodes
// hold 3.6 GB (float4 per slot and node, on the device twice and once on the host), refused under 1 GiB before
// anything is allocated, while the same request on 64 x 64 nodes runs.
TEST(TexturesService, AnAdvectionsStateCountsInTheMemoryBudget) {
  test::Daemon d({"--memory-budget", std::to_string(1ull << 30)});
  v1::AdvectTextureRequest r = noise_request(2);
  r.set_method(v1::TEXTURE_METHOD_EULERIAN_MULTILAYER);
  for (double latency : {0.1, 0.2, 0.4, 0.8, 1.6, 3.2}) r.mutable_eulerian()->add_latencies(latency);
  auto run = [&](uint32_t nodes) {
    r.mutable_eulerian()->set_grid_nx(nodes);
    r.mutable_eulerian()->set_grid_ny(nodes);
    return advect(r, d.address()).status;
  };
  const grpc::Status refused = run(2048);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << refused.error_message();
  EXPECT_NE(refused.error_message().find("AdvectTexture's frames and state"), std::string::npos)
      << refused.error_message();
  const grpc::Status ran = run(64);
  EXPECT_TRUE(ran.ok()) << ran.error_message();
}

// A checkpoint past --max-message-bytes is refused before the stream starts, by its own name even when every
// stream slot is taken: an Eulerian advection's holds float4 per slot and node, 6 latencies of 3 phases on
// 128 x 128 nodes, 4.7 MB past a limit of 1 MiB. The same request asking for no checkpoint runs.
TEST(TexturesService, ACheckpointPastTheMessageLimitIsRefusedBeforeTheStream) {
  test::Daemon d({"--max-message-bytes", std::to_string(1 << 20), "--max-streams", "1"});
  v1::AdvectTextureRequest r = noise_request(2);
  r.set_method(v1::TEXTURE_METHOD_EULERIAN_MULTILAYER);
  for (double latency : {0.1, 0.2, 0.4, 0.8, 1.6, 3.2}) r.mutable_eulerian()->add_latencies(latency);
  r.mutable_eulerian()->set_grid_nx(128);
  r.mutable_eulerian()->set_grid_ny(128);
  r.set_checkpoint_every(1);
  {
    Interactive held(d.address());  // the one slot, for as long as it is open
    ASSERT_TRUE(held.send(start(noise_request(2), 1), 1));
    test::expect_error(Code::ResourceExhausted, "TextureFrame.checkpoint with the planes",
                       [&] { throw_status(advect(r, d.address()).status); });
    EXPECT_TRUE(held.finish().ok());
  }
  r.set_checkpoint_every(0);
  const grpc::Status ran = advect(r, d.address()).status;
  EXPECT_TRUE(ran.ok()) << ran.error_message();
}

// A PNG of a uniform 16-bit RGBA colour, `side` pixels a side: a few kilobytes that decode to side^2 x 4
// samples.
std::string uniform_png(uint32_t side) {
  std::vector<uint16_t> samples(size_t(side) * side * 4, 30000);
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  image.width = image.height = side;
  image.format = PNG_FORMAT_LINEAR_RGB_ALPHA;
  png_alloc_size_t size = 0;
  png_image_write_to_memory(&image, nullptr, &size, 0, samples.data(), 0, nullptr);
  std::string bytes(size, '\0');
  png_image_write_to_memory(&image, bytes.data(), &size, 0, samples.data(), 0, nullptr);
  return bytes;
}

// An advection's inputs count in --memory-budget: a 2048^2 RGBA PNG of a few kilobytes holds 134 MB of planes
// (float32, on the host and the device), refused under 128 MiB though its frames are 16 x 16 pixels; the same
// image at 256^2 runs. A PNG whose samples alone pass the budget is refused before it is decoded.
TEST(TexturesService, AnAdvectionsInputsCountInTheMemoryBudget) {
  test::Daemon d({"--memory-budget", std::to_string(1ull << 27)});
  v1::AdvectTextureRequest r = noise_request(2);
  r.mutable_output()->set_width(16);
  r.mutable_output()->set_height(16);
  r.mutable_texture()->mutable_image()->set_png(uniform_png(2048));
  EXPECT_LT(r.texture().image().png().size(), 1u << 20);
  const grpc::Status refused = advect(r, d.address()).status;
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << refused.error_message();
  EXPECT_NE(refused.error_message().find("AdvectTexture's frames and state"), std::string::npos)
      << refused.error_message();
  r.mutable_texture()->mutable_image()->set_png(uniform_png(256));
  const grpc::Status ran = advect(r, d.address()).status;
  EXPECT_TRUE(ran.ok()) << ran.error_message();
  Limits small;
  small.memory_budget = 4 << 20;
  r.mutable_texture()->mutable_image()->set_png(uniform_png(512));  // 6.3 MB of samples and floats
  test::expect_error(Code::ResourceExhausted, "request.texture.image.png decoded", [&] { translated(r, small); });
}

// A PNG's decoded planes are held in the memory budget from before they are allocated until the call's own
// reservation counts them, so that concurrent calls with small PNGs of large images are refused rather than
// exhaust the machine: a 512^2 RGBA16 image (2.1 MB of samples, 4.2 MB of floats) fits an 8 MiB budget
// alone, and not while another call holds its floats; the samples are given back once converted.
TEST(TexturesRequest, APngsDecodedPlanesAreHeldInTheMemoryBudget) {
  Limits limits;
  limits.memory_budget = 8 << 20;
  LimitGate gate{limits};
  v1::AdvectTextureRequest r = noise_request(2);
  r.mutable_texture()->mutable_image()->set_png(uniform_png(512));
  const uint64_t floats = 512 * 512 * 4 * sizeof(float);
  Slot first;
  const textures::AdvectSpec spec = textures::rpc::spec(r, gate, first);
  EXPECT_EQ(spec.texture.pixels.size() * sizeof(float), floats);
  EXPECT_EQ(first.amount(), floats);
  EXPECT_EQ(gate.memory_bytes(), floats);
  Slot second;
  test::expect_error(Code::ResourceExhausted, "request.texture.image.png decoded",
                     [&] { textures::rpc::spec(r, gate, second); });
  EXPECT_EQ(gate.memory_bytes(), floats);
  first = Slot();
  textures::rpc::spec(r, gate, second);
  EXPECT_EQ(gate.memory_bytes(), floats);
}

// An image sent as float planes is held in the memory budget as a PNG's is, and its number of planes is
// checked before any is decoded: 8 planes of 512^2 (8 MiB of floats) are refused under a 4 MiB budget,
// held in full under a larger one, and 9 planes are refused by their count.
TEST(TexturesRequest, AnImagesFloatPlanesAreCountedAndHeldInTheMemoryBudget) {
  v1::AdvectTextureRequest r = noise_request(2);
  const std::vector<float> plane(512 * 512, 0.5f);
  for (int c = 0; c < 8; ++c)
    *r.mutable_texture()->mutable_image()->add_channels() = float_field(std::string(1, char('a' + c)), 512, 512, plane);
  const uint64_t floats = 8 * plane.size() * sizeof(float);
  LimitGate small{Limits{.memory_budget = 4 << 20}};
  Slot decoded;
  test::expect_error(Code::ResourceExhausted, "request.texture.image.channels as floats",
                     [&] { textures::rpc::spec(r, small, decoded); });
  LimitGate gate{Limits{.memory_budget = 64 << 20}};
  const textures::AdvectSpec spec = textures::rpc::spec(r, gate, decoded);
  EXPECT_EQ(spec.texture.pixels.size() * sizeof(float), floats);
  EXPECT_EQ(decoded.amount(), floats);
  *r.mutable_texture()->mutable_image()->add_channels() = float_field("c8", 512, 512, plane);
  Slot nine;
  test::expect_error(Code::InvalidArgument, "request.texture.image.channels = 9",
                     [&] { textures::rpc::spec(r, gate, nine); });
}

// A stream's reservation counts its image's decoded planes and takes over their hold: under a budget of the
// stream's reservation and half the planes, an AdvectTexture of a 1024^2 RGBA16 PNG runs, which it could not
// if the planes were held twice, and runs again, which it could not if the first call had kept either.
TEST(TexturesService, AStreamCountsItsDecodedImageOnce) {
  v1::AdvectTextureRequest r = noise_request(2);
  r.mutable_output()->set_width(16);
  r.mutable_output()->set_height(16);
  r.mutable_texture()->mutable_image()->set_png(uniform_png(1024));
  LimitGate unlimited{Limits{}};
  Slot decoded;
  const textures::AdvectSpec spec = textures::rpc::spec(r, unlimited, decoded);
  const uint64_t frame = textures::rpc::frame_bytes(spec, textures::rpc::planes(r.output()));
  const uint64_t stream = textures::rpc::stream_bytes(spec, frame), planes = decoded.amount();
  ASSERT_EQ(planes, 1024 * 1024 * 4 * sizeof(float));
  ASSERT_GE(stream, 2 * planes);  // the decoding (16-bit samples, then floats: 1.5x the planes) fits alone
  test::Daemon d({"--memory-budget", std::to_string(stream + planes / 2)});
  for (int call = 0; call < 2; ++call) {
    const grpc::Status status = advect(r, d.address()).status;
    EXPECT_TRUE(status.ok()) << "call " << call << ": " << status.error_message();
  }
}

// The engine computes every plane of a frame in float32 whichever it sends: 8 bands (8 final, 8 raw and 6
// auxiliary planes) at 2048 x 2048 pixels are 369 MB on the host and again on the device, refused under a
// 512 MiB budget though the one plane asked for, in float16, is 8 MB. The same request at 256 x 256 runs.
TEST(TexturesService, EveryPlaneTheEngineComputesCountsInTheMemoryBudget) {
  test::Daemon d({"--memory-budget", std::to_string(1ull << 29)});
  v1::AdvectTextureRequest r = noise_request(2);
  r.mutable_texture()->mutable_noise()->set_bands(8);
  r.mutable_texture()->set_final_function(v1::FINAL_FUNCTION_IDENTITY);
  r.mutable_output()->clear_planes();
  r.mutable_output()->add_planes(v1::TEXTURE_PLANE_WEIGHT_SUM);
  r.mutable_output()->set_dtype(v1::DTYPE_FLOAT16);
  auto run = [&](uint32_t pixels) {
    r.mutable_output()->set_width(pixels);
    r.mutable_output()->set_height(pixels);
    return advect(r, d.address()).status;
  };
  const grpc::Status refused = run(2048);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << refused.error_message();
  EXPECT_NE(refused.error_message().find("AdvectTexture's frames and state"), std::string::npos)
      << refused.error_message();
  const grpc::Status ran = run(256);
  EXPECT_TRUE(ran.ok()) << ran.error_message();
}

// An Eulerian advection on 3072 x 3072 nodes (seconds to lay out its start on the host, about one a step
// on the two cores; its slots' buffer, 1.36 GB, within PoCL's largest allocation of 2 GiB on a 24 GiB
// machine) under a 0.5 s deadline: squalld stops within a second of the deadline, while it lays out the
// start, and frees what it holds.
TEST(TexturesService, AnExpiredAdvectionStopsUsingTheCores) {
  v1::AdvectTextureRequest r = noise_request(50);
  r.set_method(v1::TEXTURE_METHOD_EULERIAN_MULTILAYER);
  r.mutable_eulerian()->set_grid_nx(3072);
  r.mutable_eulerian()->set_grid_ny(3072);
  const grpc::Status expired = advect(r, daemon().address(), 0.5).status;
  EXPECT_EQ(expired.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED) << expired.error_message();
  expect_daemon_stops("advecting the expired texture");
}

// A Lagrangian frame of 4096 x 4096 pixels with d = 0.05 (about 80 grids over each pixel's tile; seconds of
// reconstruction on the two cores, where laying out its grids takes milliseconds) under a 1 s deadline:
// squalld stops within a second of the deadline, between two slices of the reconstruction.
TEST(TexturesService, AnExpiredLagrangianFrameStopsUsingTheCores) {
  if (test::runtime().device_info().type != "cpu") GTEST_SKIP() << "the frame is sized for a CPU device's pace";
  v1::AdvectTextureRequest r = noise_request(1);
  r.mutable_output()->set_width(4096);
  r.mutable_output()->set_height(4096);
  r.mutable_output()->clear_planes();
  r.mutable_output()->set_dtype(v1::DTYPE_FLOAT16);  // within the message limit
  r.mutable_lagrangian()->set_d(0.05);
  const grpc::Status expired = advect(r, daemon().address(), 1).status;
  EXPECT_EQ(expired.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED) << expired.error_message();
  expect_daemon_stops("reconstructing the expired frame");
}

// FINAL_FUNCTION_LUT (LTA11 sec. 3.2): a 3-channel table and a 3 x 2 scalar field give planes final_0..2
// equal to the engine's; a NaN entry, a LUT band shaping and a mis-sized field name their fields.
TEST(TexturesService, LookupFinalFunctionMatchesTheEngine) {
  v1::AdvectTextureRequest r = noise_request(2);
  r.mutable_texture()->set_final_function(v1::FINAL_FUNCTION_LUT);
  auto* lut = r.mutable_texture()->mutable_lut();
  lut->set_channels(3);
  for (float v : {0.0f, 0.1f, 0.9f, 1.0f, 0.6f, 0.2f, 0.3f, 1.0f, 0.0f}) lut->add_table(v);
  lut->set_lut_max(2);
  auto* s = lut->mutable_field();
  s->set_nx(3);
  s->set_ny(2);
  s->mutable_spacing()->set_x(0.5);
  s->mutable_spacing()->set_y(1);
  *s->mutable_values() = float_field("s", 3, 2, {0, 0.5f, 1, 0.2f, 0.7f, 1.2f});
  Streamed got = advect(r);
  expect_well_formed(got, r);
  ASSERT_EQ(got.frames.size(), 2u);
  EXPECT_EQ(got.frames[0].planes(2).name(), "final_2");
  EXPECT_EQ(got.frames[0].planes(3).name(), "raw_0");
  auto want = in_process(r);
  for (size_t i = 0; i < want.size(); ++i) expect_same(got.frames[i], want[i]);

  v1::AdvectTextureRequest bad = r;
  bad.mutable_texture()->mutable_lut()->set_table(4, NAN);
  test::expect_error(Code::InvalidArgument, "request.texture.lut.table[4] = nan must be finite",
                     [&] { advect_or_throw(bad); });
  bad = r;
  bad.mutable_texture()->mutable_lut()->set_band_shape(v1::FINAL_FUNCTION_LUT);
  test::expect_error(Code::InvalidArgument, "request.texture.lut.band_shape = 5", [&] { advect_or_throw(bad); });
  bad = r;
  *bad.mutable_texture()->mutable_lut()->mutable_field()->mutable_values() = float_field("s", 2, 2, {0, 0, 0, 0});
  test::expect_error(Code::InvalidArgument, "request.texture.lut.field.values.nx = 2", [&] { advect_or_throw(bad); });
}

// `squall texture advect` writes numbered EXR frames and PNG previews; a bad flag exits 2.
TEST(TexturesCli, AdvectWritesFrames) {
  const std::string dir = test::temp_dir("textures-cli");
  std::string out;
  std::vector<std::string> argv = {test::squall_path(),
                                   "--address",
                                   daemon().address(),
                                   "texture",
                                   "advect",
                                   "--frames",
                                   "2",
                                   "--size",
                                   "32x32",
                                   "--velocity",
                                   "vortex:0.5,0.5,0.5",
                                   "--noise",
                                   "3,4,2",
                                   "--final",
                                   "turbulence",
                                   "--planes",
                                   "final,raw",
                                   "--out",
                                   dir};
  ASSERT_EQ(test::run(argv, &out), 0) << out;
  for (const char* name : {"frame_0000.exr", "frame_0000.png", "frame_0001.exr", "frame_0001.png"}) {
    ASSERT_TRUE(std::filesystem::exists(dir + "/" + name)) << name << "\n" << out;
    EXPECT_GT(std::filesystem::file_size(dir + "/" + name), 0u) << name;
  }
  EXPECT_EQ(test::run({test::squall_path(), "--address", daemon().address(), "texture", "advect", "--method", "magic",
                       "--out", dir},
                      &out),
            2)
      << out;
  EXPECT_EQ(test::run({test::squall_path(), "--address", daemon().address(), "texture", "advect", "--method",
                       "eulerian", "--d", "0.2", "--out", dir},
                      &out),
            2)
      << out;
  EXPECT_NE(out.find("--d is the Lagrangian grids' Poisson radius: not a flag of --method eulerian"), std::string::npos)
      << out;
  // Flags the request would carry unused exit 2 too: a seed with a method that places no particles, and an
  // image with noise flags (the last texture flag would have won).
  const std::string png = dir + "/frame_0000.png";
  for (const auto& [flags, message] : std::vector<std::pair<std::vector<std::string>, std::string>>{
           {{"--method", "naive", "--seed", "7"}, "--seed places the Lagrangian grids: not a flag of --method naive"},
           {{"--image", png, "--noise", "2"}, "--image is the texture: --noise and --spin are flags of a noise"},
           {{"--spin", "3", "--image", png}, "--image is the texture"},
           // A velocity's numbers are named with its kind, also when none are given.
           {{"--velocity", "uniform"}, "--velocity uniform: needs 2 numbers, none given"},
           {{"--velocity", "uniform:1"}, "--velocity uniform 1: needs 2 numbers"},
           {{"--velocity", "bogus:1"}, "--velocity bogus:1: uniform, rotation"}}) {
    std::vector<std::string> bad = {test::squall_path(), "--address", daemon().address(), "texture", "advect"};
    bad.insert(bad.end(), flags.begin(), flags.end());
    bad.insert(bad.end(), {"--out", dir + "/unused"});
    EXPECT_EQ(test::run(bad, &out), 2) << out;
    EXPECT_NE(out.find(message), std::string::npos) << out;
    EXPECT_FALSE(std::filesystem::exists(dir + "/unused"));
  }
}

// The last --image given is the texture: a five-channel image given twice is five channels, not ten (past
// the eight a texture may have). An image file that is a folder, or empty, exits 2 naming the flag.
TEST(TexturesCli, TheLastImageGivenIsTheTexture) {
  const std::string dir = test::temp_dir("textures-cli-image");
  client::Image image;
  image.nx = image.ny = 8;
  for (const char* name : {"R", "G", "B", "A", "mask"}) image.channels.push_back({name, std::vector<float>(64, 0.5f)});
  client::write_exr(dir + "/five.exr", image);
  std::string out;
  auto advect = [&](const std::string& first, const std::string& second) {
    return test::run({test::squall_path(), "--address", daemon().address(), "texture", "advect", "--frames", "1",
                      "--size", "8x8", "--image", first, "--image", second, "--out", dir + "/frames"},
                     &out);
  };
  EXPECT_EQ(advect(dir + "/five.exr", dir + "/five.exr"), 0) << out;
  std::filesystem::create_directories(dir + "/folder.exr");
  std::ofstream(dir + "/empty.png");
  EXPECT_EQ(advect(dir + "/five.exr", dir + "/folder.exr"), 2) << out;
  EXPECT_NE(out.find("--image " + dir + "/folder.exr: cannot read it"), std::string::npos) << out;
  EXPECT_EQ(advect(dir + "/five.exr", dir + "/empty.png"), 2) << out;
  EXPECT_NE(out.find("the file is empty"), std::string::npos) << out;
}

}  // namespace
}  // namespace squall
