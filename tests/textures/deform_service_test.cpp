// Content-aware deformation through a real squalld: DeformTexture's frames equal the engine's in this
// process bit for bit for every control; DeformInteractive applies each message's control (d mu, its map,
// the deformation gradient, brush strokes) from its next frame on, as the engine's steer does; bad requests
// get INVALID_ARGUMENT naming the field; `squall texture deform` writes EXR and PNG frames.
#include <gtest/gtest.h>

#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfStringAttribute.h>

#include <cmath>
#include <filesystem>
#include <functional>
#include <fstream>

#include "common/field_codec.h"
#include "service_support.h"
#include "support/expect_error.h"
#include "support/in_process.h"
#include "support/process.h"
#include "support/test_runtime.h"
#include "textures/deform.h"
#include "textures/deform_request.h"
#include "textures/textures_service.h"

namespace squall {
namespace {

using namespace squall::textures_test;
constexpr int kSize = 48;

textures::DeformEngine& deformer() {
  static LimitGate gate{Limits{}};
  static textures::DeformEngine engine(test::runtime(), gate);
  return engine;
}

struct DeformInteractive : InteractiveCall<v1::DeformControl, v1::DeformFrame> {
  explicit DeformInteractive(const std::string& address = daemon().address())
      : InteractiveCall([](v1::Textures::Stub& s, grpc::ClientContext* c) { return s.DeformInteractive(c); },
                        address) {}
};

// A `size` x `size` (48 by default) two-channel texture (stripes and rings), R = 1 in a disk at the centre
// and -1 around it.
v1::DeformTextureRequest request(v1::DeformControlKind control, uint32_t frames, int size = kSize) {
  v1::DeformTextureRequest r;
  const size_t texels = size_t(size) * size_t(size);
  std::vector<float> a(texels), b(texels), rigidity(texels);
  for (int j = 0; j < size; ++j) {
    for (int i = 0; i < size; ++i) {
      const size_t k = size_t(j) * size + i;
      const double dx = i + 0.5 - size / 2.0, dy = j + 0.5 - size / 2.0;
      a[k] = float(0.5 + 0.5 * std::sin(0.7 * i));
      b[k] = float(0.5 + 0.5 * std::cos(0.4 * std::hypot(dx, dy)));
      rigidity[k] = dx * dx + dy * dy < 100 ? 1.0f : -1.0f;
    }
  }
  *r.mutable_texture()->add_channels() = float_field("a", size, size, a);
  *r.mutable_texture()->add_channels() = float_field("b", size, size, b);
  *r.mutable_rigidity() = float_field("R", size, size, rigidity);
  r.set_control(control);
  r.set_d_mu(0.5);
  std::vector<float> map(texels);
  for (size_t k = 0; k < texels; ++k) map[k] = float(k % size) / size;
  *r.mutable_d_mu_map() = float_field("map", size, size, map);
  r.mutable_deformation_end()->set_xx(1.5);
  r.mutable_deformation_end()->set_yy(1.0);
  v1::BrushStroke* stroke = r.add_strokes();
  stroke->mutable_center()->set_x(12);
  stroke->mutable_center()->set_y(30);
  stroke->set_radius(4);
  stroke->set_strength(2);
  r.set_frames(frames);
  r.set_substeps(4);
  r.add_planes(v1::DEFORM_PLANE_COLOR);
  r.add_planes(v1::DEFORM_PLANE_WARP);
  r.add_planes(v1::DEFORM_PLANE_REFERENCE);
  r.add_planes(v1::DEFORM_PLANE_LEVEL);
  r.add_planes(v1::DEFORM_PLANE_FLOW);
  r.set_stack_levels(control == v1::DEFORM_CONTROL_CONSTANT ? 2 : 0);
  return r;
}

using DeformStreamed = StreamedOf<v1::DeformFrame>;

// DeformTexture read to its end, under a deadline of `timeout` s, from the daemon at `address`.
DeformStreamed deform(const v1::DeformTextureRequest& r, double timeout = 300,
                      const std::string& address = daemon().address()) {
  return read_stream<v1::DeformFrame>(
      [&](v1::Textures::Stub& service, grpc::ClientContext* c) { return service.DeformTexture(c, r); }, address,
      timeout);
}

void deform_or_throw(const v1::DeformTextureRequest& r) { throw_status(deform(r).status); }

void expect_same(const v1::DeformFrame& got, const textures::DeformFrame& want, const textures::FlowSolve& flow,
                 const v1::DeformTextureRequest& r) {
  v1::DeformFrame encoded;
  textures::rpc::fill_frame(want, flow, textures::rpc::deform_planes(r), r.texture().channels_size(), r.dtype(),
                            &encoded);
  ASSERT_EQ(got.planes_size(), encoded.planes_size());
  for (int k = 0; k < got.planes_size(); ++k) {
    EXPECT_EQ(got.planes(k).name(), encoded.planes(k).name());
    EXPECT_EQ(got.planes(k).data(), encoded.planes(k).data()) << got.index() << " " << got.planes(k).name();
  }
  EXPECT_EQ(got.max_warp(), encoded.max_warp());
  EXPECT_EQ(got.solver_iterations(), encoded.solver_iterations());
}

TEST(TexturesDeform, EveryControlStreamsTheEnginesFrames) {
  for (auto control : {v1::DEFORM_CONTROL_CONSTANT, v1::DEFORM_CONTROL_MAP, v1::DEFORM_CONTROL_ISOTROPIC,
                       v1::DEFORM_CONTROL_ANISOTROPIC, v1::DEFORM_CONTROL_BRUSH}) {
    const v1::DeformTextureRequest r = request(control, 4);
    const DeformStreamed got = deform(r);
    ASSERT_TRUE(got.status.ok()) << got.status.error_message();
    ASSERT_EQ(got.frames.size(), 4u) << control;
    const textures::DeformSpec spec = translated(r);
    auto deformation = deformer().start(spec);
    const textures::DeformPlanes planes = textures::rpc::deform_planes(r);
    for (const v1::DeformFrame& frame : got.frames)
      expect_same(frame, deformation->next(planes), deformation->flow(), r);
    EXPECT_EQ(got.frames[0].max_warp(), 0.0) << "frame 0 is the undeformed texture";
    EXPECT_GT(got.frames[3].max_warp(), 0.01) << control;
    EXPECT_EQ(got.frames[0].planes(0).name(), "color_0");
    EXPECT_LT(got.frames[0].solver_residual(), 1e-5);
  }
}

TEST(TexturesDeform, InteractiveMessagesSteerFromTheNextFrame) {
  v1::DeformTextureRequest r = request(v1::DEFORM_CONTROL_BRUSH, 0);
  r.clear_strokes();  // no brush at first: nothing moves
  r.clear_deformation_end();
  DeformInteractive call;
  v1::DeformControl first;
  *first.mutable_start() = r;
  first.set_frames(2);
  ASSERT_TRUE(call.send(first, 2));
  v1::DeformControl stroke;
  *stroke.add_strokes() = request(v1::DEFORM_CONTROL_BRUSH, 0).strokes(0);
  stroke.set_frames(3);
  ASSERT_TRUE(call.send(stroke, 3));
  v1::DeformControl cleared;
  cleared.set_clear_strokes(true);
  cleared.set_frames(2);
  ASSERT_TRUE(call.send(cleared, 2));
  ASSERT_TRUE(call.finish().ok());
  const auto& f = call.frames();
  ASSERT_EQ(f.size(), 7u);
  EXPECT_EQ(f[1].max_warp(), 0.0);  // no stroke yet
  EXPECT_GT(f[2].max_warp(), 0.0);  // the stroke acts from the next frame
  EXPECT_GT(f[4].max_warp(), f[2].max_warp());
  EXPECT_EQ(f[6].max_warp(), f[4].max_warp());  // cleared: the warp holds

  LimitGate gate{Limits{}};
  Slot decoded;
  textures::DeformSpec spec = textures::rpc::deform_start(first, gate, decoded, "control[0]");
  auto deformation = deformer().start(spec);
  r.set_frames(1);
  for (int i = 0; i < 2; ++i)
    expect_same(f[i], deformation->next(textures::rpc::deform_planes(r)), deformation->flow(), r);
  textures::rpc::steer(stroke, spec, "control[1]");
  deformation->steer(spec.control);
  for (int i = 2; i < 5; ++i)
    expect_same(f[i], deformation->next(textures::rpc::deform_planes(r)), deformation->flow(), r);
}

TEST(TexturesDeform, TensorControlFollowsTheGradientSentEachMessage) {
  v1::DeformTextureRequest r = request(v1::DEFORM_CONTROL_ISOTROPIC, 0);
  r.clear_deformation_end();
  DeformInteractive call;
  v1::DeformControl first;
  *first.mutable_start() = r;
  first.set_frames(1);
  ASSERT_TRUE(call.send(first, 1));
  double last = 0;
  for (double stretch : {1.1, 1.2, 1.3, 1.2, 1.1, 1.0}) {  // out to 1.3 and back to the rest shape
    v1::DeformControl m;
    m.mutable_deformation()->set_xx(stretch);
    m.mutable_deformation()->set_yy(1);
    ASSERT_TRUE(call.send(m, 1));
    last = call.frames().back().max_warp();
    if (stretch == 1.3) {
      EXPECT_GT(last, 0.05);
    }
  }
  ASSERT_TRUE(call.finish().ok());
  EXPECT_LT(last, 0.1) << "the isotropic control is reversible (eq. 7)";
}

// A flow solve of 100000 CGLS iterations on 1024 x 1024 texels (minutes of the two cores) under a 1 s
// deadline: squalld stops solving within a second of the deadline, between two iterations.
TEST(TexturesDeform, AnExpiredFlowSolveStopsUsingTheCores) {
  constexpr uint32_t n = 1024;
  v1::DeformTextureRequest r;
  std::vector<float> texture(n * n), rigidity(n * n);
  for (uint32_t k = 0; k < n * n; ++k) {
    texture[k] = float(k % 7) / 7;
    rigidity[k] = (k * 2654435761u) >> 31 ? 1.0f : -1.0f;  // rigid and elastic texels mixed at random
  }
  *r.mutable_texture()->add_channels() = float_field("a", n, n, texture);
  *r.mutable_rigidity() = float_field("R", n, n, rigidity);
  r.set_control(v1::DEFORM_CONTROL_CONSTANT);
  r.set_d_mu(0.5);
  r.set_frames(1);
  r.set_tolerance(1e-12);
  r.set_max_iterations(100000);
  r.add_planes(v1::DEFORM_PLANE_FLOW);
  const grpc::Status expired = deform(r, 1).status;
  EXPECT_EQ(expired.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED) << expired.error_message();
  expect_daemon_stops("solving the expired flow");
}

// A resampling stack of 16 levels each way over 700 x 700 texels (about 1e9 flow samples: seconds of the two
// cores; R = 0 everywhere, so the flow solve ends at once) under a 1 s deadline: squalld stops building it
// within a second of the deadline, between two slices of texels.
TEST(TexturesDeform, AnExpiredStackBuildStopsUsingTheCores) {
  if (test::runtime().device_info().type != "cpu") GTEST_SKIP() << "the stack is sized for a CPU device's pace";
  constexpr uint32_t n = 700;
  v1::DeformTextureRequest r;
  std::vector<float> texture(n * n);
  for (uint32_t k = 0; k < n * n; ++k) texture[k] = float(k % 7) / 7;
  *r.mutable_texture()->add_channels() = float_field("a", n, n, texture);
  *r.mutable_rigidity() = float_field("R", n, n, std::vector<float>(n * n, 0.0f));
  r.set_control(v1::DEFORM_CONTROL_CONSTANT);
  r.set_d_mu(0.5);
  r.set_frames(1);
  r.set_stack_levels(16);
  r.add_planes(v1::DEFORM_PLANE_LEVEL);
  const grpc::Status expired = deform(r, 1).status;
  EXPECT_EQ(expired.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED) << expired.error_message();
  expect_daemon_stops("building the expired stack");
}

// A deformation holds its state, its flow and, while it solves the flow, CGLS's buffers in double: about 160
// bytes a texel. Two channels of 1024^2 texels are 160 MB, refused under a 128 MiB budget though the one
// float16 plane a frame sends is 4 MB; the same request at 48^2 runs.
TEST(TexturesDeform, TheDeformationsStateCountsInTheMemoryBudget) {
  test::Daemon d({"--memory-budget", std::to_string(1ull << 27)});
  for (const auto& [size, code] :
       {std::pair{1024, grpc::StatusCode::RESOURCE_EXHAUSTED}, std::pair{kSize, grpc::StatusCode::OK}}) {
    v1::DeformTextureRequest r = request(v1::DEFORM_CONTROL_ISOTROPIC, 2, size);
    r.clear_planes();
    r.add_planes(v1::DEFORM_PLANE_REFERENCE);
    r.set_dtype(v1::DTYPE_FLOAT16);
    const DeformStreamed got = deform(r, 300, d.address());
    EXPECT_EQ(got.status.error_code(), code) << size << ": " << got.status.error_message();
    if (!got.status.ok()) {
      EXPECT_NE(got.status.error_message().find("the deformation's state and frames"), std::string::npos);
    }
  }
}

// A d mu map steered into a stream that started without one is held twice (the stream's spec, the running
// control) and reserved in the memory budget as it comes; a second map replaces it.
TEST(TexturesDeform, AMapSteeredInIsReservedInTheMemoryBudget) {
  test::InProcess<rpc::TexturesService> server;
  const LimitGate& gate = server.serving().gate();
  DeformInteractive call(server.address());
  v1::DeformControl first;
  *first.mutable_start() = request(v1::DEFORM_CONTROL_ISOTROPIC, 0);
  first.mutable_start()->clear_deformation_end();
  first.mutable_start()->clear_d_mu_map();
  ASSERT_TRUE(call.send(first, 1));
  const uint64_t before = gate.memory_bytes();
  v1::DeformControl map;
  *map.mutable_d_mu_map() = first.start().rigidity();
  ASSERT_TRUE(call.send(map, 1));
  EXPECT_EQ(gate.memory_bytes() - before, 2 * sizeof(float) * kSize * kSize);
  ASSERT_TRUE(call.send(map, 1));
  EXPECT_EQ(gate.memory_bytes() - before, 2 * sizeof(float) * kSize * kSize);
  EXPECT_TRUE(call.finish().ok());
}

TEST(TexturesDeform, BadRequestsNameTheField) {
  v1::DeformTextureRequest r = request(v1::DEFORM_CONTROL_CONSTANT, 2);
  r.clear_rigidity();
  test::expect_error(Code::InvalidArgument, "request.rigidity is unset", [&] { deform_or_throw(r); });
  r = request(v1::DEFORM_CONTROL_CONSTANT, 2);
  std::vector<float> bad(kSize * kSize, 2.0f);
  *r.mutable_rigidity() = float_field("R", kSize, kSize, bad);
  test::expect_error(Code::InvalidArgument, "request.rigidity", [&] { deform_or_throw(r); });
  r = request(v1::DEFORM_CONTROL_CONSTANT, 2);
  *r.mutable_rigidity() = float_field("R", kSize, 4, std::vector<float>(kSize * 4));
  test::expect_error(Code::InvalidArgument, "request.rigidity.ny", [&] { deform_or_throw(r); });
  r = request(v1::DEFORM_CONTROL_CONSTANT, 2, 3);  // the size is the planes': no width field to name
  r.set_stack_levels(0);
  test::expect_error(Code::InvalidArgument, "request.texture is 3 x 3 texels", [&] { deform_or_throw(r); });
  r = request(v1::DEFORM_CONTROL_BRUSH, 2);
  r.mutable_strokes(0)->set_radius(0);
  test::expect_error(Code::InvalidArgument, "request.strokes[0].radius", [&] { deform_or_throw(r); });
  r = request(v1::DEFORM_CONTROL_CONSTANT, 2);
  r.set_d_mu(NAN);
  test::expect_error(Code::InvalidArgument, "request.d_mu", [&] { deform_or_throw(r); });
  for (const auto& [edit, needle] : std::vector<std::pair<std::function<void(v1::DeformTextureRequest&)>, std::string>>{
           {[](auto& q) { q.set_frames(4294967295u); }, "request.frames = 4294967295 must be in [1, 100000]"},
           {[](auto& q) { q.set_substeps(4294967295u); }, "request.substeps = 4294967295 must be in [1, 100]"},
           {[](auto& q) { q.set_stack_levels(4294967295u); }, "request.stack_levels = 4294967295 must be in [0, 16]"},
           {[](auto& q) { q.set_max_iterations(4294967295u); }, "request.max_iterations = 4294967295 must be in"}}) {
    r = request(v1::DEFORM_CONTROL_CONSTANT, 2);  // counts are named as sent, not capped
    edit(r);
    test::expect_error(Code::InvalidArgument, needle, [&] { deform_or_throw(r); });
  }
  r = request(v1::DEFORM_CONTROL_CONSTANT, 2);
  r.set_control(v1::DeformControlKind(17));
  test::expect_error(Code::InvalidArgument, "request.control = 17", [&] { deform_or_throw(r); });

  // Eq. 8's log(vb^T T vb) where a frame's T turns a direction by 120 degrees (a rotation, det 1): undefined
  // for the texels whose flow points there, refused for the ramp and for a steered G.
  v1::Tensor2 turned;
  turned.set_xx(-0.5);
  turned.set_xy(-0.866);
  turned.set_yx(0.866);
  turned.set_yy(-0.5);
  r = request(v1::DEFORM_CONTROL_ANISOTROPIC, 2);
  *r.mutable_deformation_end() = turned;
  test::expect_error(Code::InvalidArgument, "request.deformation_end turns some direction by 90 degrees or more",
                     [&] { deform_or_throw(r); });
  r.set_frames(4);  // the same turn over three frames
  EXPECT_TRUE(deform(r).status.ok());
  DeformInteractive turning;
  v1::DeformControl anisotropic;
  *anisotropic.mutable_start() = request(v1::DEFORM_CONTROL_ANISOTROPIC, 0);
  anisotropic.mutable_start()->clear_deformation_end();
  ASSERT_TRUE(turning.send(anisotropic, 1));
  v1::DeformControl steer;
  *steer.mutable_deformation() = turned;
  turning.send(steer, 0);
  test::expect_error(Code::InvalidArgument, "control[1].deformation turns some direction by 90 degrees",
                     [&] { throw_status(turning.finish()); });

  DeformInteractive call;
  v1::DeformControl first;
  *first.mutable_start() = request(v1::DEFORM_CONTROL_ISOTROPIC, 0);
  first.mutable_start()->clear_deformation_end();  // messages steer it
  ASSERT_TRUE(call.send(first, 1));
  v1::DeformControl flipped;
  flipped.mutable_deformation()->set_xx(-1);
  flipped.mutable_deformation()->set_yy(1);
  call.send(flipped, 0);
  test::expect_error(Code::InvalidArgument, "control[1].deformation determinant", [&] { throw_status(call.finish()); });
  DeformInteractive nan_call;
  ASSERT_TRUE(nan_call.send(first, 1));
  v1::DeformControl bad_d_mu;
  bad_d_mu.set_d_mu(NAN);
  nan_call.send(bad_d_mu, 0);
  test::expect_error(Code::InvalidArgument, "control[1].d_mu = nan", [&] { throw_status(nan_call.finish()); });
  // A map is checked whenever one is sent, also with a control that does not use it.
  DeformInteractive nan_map_call;
  ASSERT_TRUE(nan_map_call.send(first, 1));
  v1::DeformControl nan_map;
  *nan_map.mutable_d_mu_map() = float_field("map", kSize, kSize, std::vector<float>(kSize * kSize, NAN));
  nan_map_call.send(nan_map, 0);
  test::expect_error(Code::InvalidArgument, "control[1].d_mu_map[0] = nan",
                     [&] { throw_status(nan_map_call.finish()); });
  // An interactive deformation holds deformation_start until a message steers it: an end tensor in its
  // start would be dropped unread, so it is refused.
  v1::DeformControl with_end = first;
  with_end.mutable_start()->mutable_deformation_end()->set_xx(2);
  with_end.mutable_start()->mutable_deformation_end()->set_yy(2);
  LimitGate gate{Limits{}};
  Slot decoded;
  test::expect_error(Code::InvalidArgument, "control[0].start.deformation_end is set",
                     [&] { textures::rpc::deform_start(with_end, gate, decoded, "control[0]"); });
}

TEST(TexturesDeform, CommandLine) {
  const std::string dir = test::temp_dir("textures-deform-cli");
  std::string out;
  ASSERT_EQ(test::run({test::squall_path(), "--address", daemon().address(), "texture", "advect", "--size", "32x32",
                       "--frames", "1", "--final", "sum", "--out", dir + "/source"},
                      &out),
            0)
      << out;
  ASSERT_EQ(test::run({test::squall_path(), "--address", daemon().address(), "texture", "deform", "--image",
                       dir + "/source/frame_0000.png", "--rigidity", "0.5", "--control", "brush:16,16,4,1", "--frames",
                       "3", "--dt", "0.25", "--planes", "color,warp", "--out", dir + "/deformed"},
                      &out),
            0)
      << out;
  for (const char* name : {"frame_0000.exr", "frame_0000.png", "frame_0002.exr", "frame_0002.png"})
    EXPECT_TRUE(std::filesystem::exists(dir + "/deformed/" + name)) << name << "\n" << out;
  EXPECT_NE(out.find("wrote 3 frames"), std::string::npos) << out;
  Imf::InputFile frame2((dir + "/deformed/frame_0002.exr").c_str());
  const auto* time = frame2.header().findTypedAttribute<Imf::StringAttribute>("squall.time_seconds");
  ASSERT_NE(time, nullptr);
  EXPECT_EQ(time->value(), "0.5");  // frame 2 at --dt 0.25
  // --kappa scales the d mu of maps and tensors only: with a brush it would be sent and unused.
  EXPECT_EQ(test::run({test::squall_path(), "--address", daemon().address(), "texture", "deform", "--image",
                       dir + "/source/frame_0000.png", "--rigidity", "0.5", "--kappa", "2", "--control",
                       "brush:16,16,4,1", "--out", dir + "/x"},
                      &out),
            2)
      << out;
  EXPECT_NE(out.find("--kappa scales the d mu of --control map, isotropic and anisotropic: not a flag of brush"),
            std::string::npos)
      << out;
  EXPECT_EQ(test::run({test::squall_path(), "--address", daemon().address(), "texture", "deform", "--image",
                       dir + "/source/frame_0000.png", "--out", dir + "/x"},
                      &out),
            2)
      << out;
  // A constant rigidity takes the texture's size from its PNG header: only a PNG's, and not past 2^24 texels
  // (a map of 64 MiB, squalld's default message limit).
  std::string forged = "\x89PNG\r\n\x1a\n" + std::string("\0\0\0\x0dIHDR\0\0\x9c\x40\0\0\x9c\x40", 16);
  std::ofstream(dir + "/forged.png", std::ios::binary) << forged << std::string(16, '\0');
  std::string wide = "\x89PNG\r\n\x1a\n" + std::string("\0\0\0\x0dIHDR\0\0\x13\x88\0\0\x13\x88", 16);
  std::ofstream(dir + "/wide.png", std::ios::binary) << wide << std::string(16, '\0');
  std::ofstream(dir + "/text.png") << "this is not a png, but long enough to have a header";
  for (const auto& [file, message] : std::vector<std::pair<std::string, std::string>>{
           {"forged.png", "the PNG header says 40000 x 40000 pixels: must be 1 to 2^24"},
           {"wide.png", "the PNG header says 5000 x 5000 pixels: must be 1 to 2^24"},
           {"text.png", "not a PNG file"}}) {
    EXPECT_EQ(test::run({test::squall_path(), "--address", daemon().address(), "texture", "deform", "--image",
                         dir + "/" + file, "--rigidity", "0.5", "--out", dir + "/y"},
                        &out),
              2)
        << out;
    EXPECT_NE(out.find(message), std::string::npos) << out;
  }
}

}  // namespace
}  // namespace squall
