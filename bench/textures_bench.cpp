// Advected-texture frames per second at 256^2, 512^2 and 1024^2 output, in one run, for Lagrangian grids
// (Q. Yu, F. Neyret, E. Bruneton, N. Holzschuch, "Lagrangian Texture Advection", IEEE TVCG 2011: direct
// reconstruction, d = 0.05 of the width, about 300-450 grids of 8 x 8 as in its sec. 4.2), the three-layer
// Eulerian method (F. Neyret, "Advected Textures", SCA 2003) and the two-phase flow map:
//   (a) in process: TextureEngine on this machine's device, every plane read back each frame;
//   (b) through squall.v1.Textures/AdvectTexture against a squalld (--address), the final plane streamed.
// Four bands of noise summed (F = SUM_BANDS) advected by a Rankine vortex. Prints frames/s, the ratio
// stream/process, Lagrangian/flow-map at equal output, the particles alive and the share of the frame
// spent in host maintenance (particle kill/insert and vertex weights).
//
//   build/bench/textures_bench [--device auto|cpu|gpu|NAME] [--address HOST:PORT] [--seconds S]
//                              [--kernel-dir DIR (kernels from DIR, e.g. another commit's)]
#include <grpcpp/grpcpp.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>

#include "bench_util.h"
#include "runtime/runtime.h"
#include "squall/v1/textures.grpc.pb.h"
#include "textures/texture_engine.h"

using namespace squall;
using namespace squall::textures;
using Clock = std::chrono::steady_clock;

namespace {

constexpr int kWarmup = 10;  // frames before timing: particles reach their steady turnover

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

AdvectSpec spec_of(Method method, int size) {
  AdvectSpec spec;
  spec.method = method;
  spec.velocity.kind = SQUALL_VELOCITY_VORTEX;
  spec.velocity.params = {0.3, 0.5, 0.5, 0.15};
  spec.texture.bands = 4;
  spec.texture.final_function = SQUALL_FINAL_SUM_BANDS;
  spec.output = {size, size, 0, 0, 1, 1};
  spec.lagrangian.d = 0.05;
  if (method == Method::TwoPhaseFlowMap) spec.eulerian.latencies = {1.0};
  spec.frames = 100000;
  return spec;
}

struct InProcess {
  double fps = 0, maintain_share = 0;
  int alive = 0;
};

InProcess in_process(TextureEngine& engine, const AdvectSpec& spec, double budget) {
  auto advection = engine.start(spec);
  for (int i = 0; i < kWarmup; ++i) advection->next();
  InProcess r;
  double maintain_ms = 0;
  int frames = 0;
  auto start = Clock::now();
  while (frames < 3 || seconds_since(start) < budget) {
    TextureFrame frame = advection->next();
    for (const auto& [stage, ms] : frame.stats.stage_ms) maintain_ms += stage == "maintain" ? ms : 0;
    r.alive = frame.stats.particles.alive;
    ++frames;
  }
  double elapsed = seconds_since(start);
  r.fps = frames / elapsed;
  r.maintain_share = maintain_ms / 1000 / elapsed;
  return r;
}

squall::v1::AdvectTextureRequest request_of(Method method, int size, int frames) {
  squall::v1::AdvectTextureRequest request;
  const squall::v1::TextureMethod methods[] = {
      squall::v1::TEXTURE_METHOD_LAGRANGIAN_GRIDS, squall::v1::TEXTURE_METHOD_EULERIAN_MULTILAYER,
      squall::v1::TEXTURE_METHOD_TWO_PHASE_FLOW_MAP, squall::v1::TEXTURE_METHOD_NAIVE};
  request.set_method(methods[int(method)]);
  auto* vortex = request.mutable_velocity()->mutable_named();
  vortex->set_kind(squall::v1::AnalyticVelocity::KIND_RANKINE_VORTEX);
  vortex->set_circulation(0.3);
  vortex->set_core_radius(0.15);
  auto* texture = request.mutable_texture();
  texture->mutable_noise()->set_bands(4);
  texture->set_final_function(squall::v1::FINAL_FUNCTION_SUM_BANDS);
  request.mutable_output()->set_width(size);
  request.mutable_output()->set_height(size);
  request.mutable_lagrangian()->set_d(0.05);
  if (method == Method::TwoPhaseFlowMap) request.mutable_eulerian()->add_latencies(1.0);
  request.set_frames(frames);
  return request;
}

// Frames/s of one AdvectTexture stream after its first kWarmup frames.
double through_stream(squall::v1::Textures::Stub& textures, Method method, int size, double expected_fps,
                      double budget) {
  const int timed = std::max(3, int(expected_fps * budget));
  grpc::ClientContext context;
  auto reader = textures.AdvectTexture(&context, request_of(method, size, kWarmup + timed));
  squall::v1::TextureFrame frame;
  int read = 0;
  Clock::time_point start;
  while (reader->Read(&frame)) {
    if (++read == kWarmup) start = Clock::now();
  }
  grpc::Status status = reader->Finish();
  if (!status.ok() || read != kWarmup + timed) {
    std::fprintf(stderr, "AdvectTexture failed: %s (%d frames)\n", status.error_message().c_str(), read);
    return 0;
  }
  return timed / seconds_since(start);
}

}  // namespace

int bench_main(int argc, char** argv) {
  RuntimeOptions options;
  options.program_prefixes = {"runtime/", "textures/"};
  std::string address;
  double budget = 3;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--device")) options.device = argv[i + 1];
    if (!std::strcmp(argv[i], "--address")) address = argv[i + 1];
    if (!std::strcmp(argv[i], "--seconds")) budget = std::stod(argv[i + 1]);
    if (!std::strcmp(argv[i], "--kernel-dir")) options.kernel_dir = argv[i + 1];  // other kernels, same host code
  }
  configure_kernel_cache();
  Runtime runtime(options);
  runtime.build_programs();
  LimitGate gate{Limits{}};
  TextureEngine engine(runtime, gate);
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(-1);
  auto textures =
      squall::v1::Textures::NewStub(grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), args));

  std::printf("device: %s; squalld: %s\n", describe(runtime.device_info()).c_str(),
              address.empty() ? "none (--address not given)" : address.c_str());
  std::printf("frames/s, 4 noise bands summed, Rankine vortex; >= %.0f s per cell\n\n", budget);
  std::printf("%-6s %-12s %10s %10s %10s %9s %10s %12s\n", "size", "method", "process", "stream", "str/proc", "alive",
              "host share", "lagr/flowmap");
  const std::pair<Method, const char*> methods[] = {{Method::LagrangianGrids, "lagrangian"},
                                                    {Method::EulerianMultilayer, "eulerian-3"},
                                                    {Method::TwoPhaseFlowMap, "flow-map"}};
  for (int size : {256, 512, 1024}) {
    double lagrangian_fps = 0;
    for (auto [method, name] : methods) {
      InProcess a = in_process(engine, spec_of(method, size), budget);
      double b = address.empty() ? 0 : through_stream(*textures, method, size, a.fps, budget);
      if (method == Method::LagrangianGrids) lagrangian_fps = a.fps;
      double versus = method == Method::TwoPhaseFlowMap ? a.fps / lagrangian_fps : 0;
      std::printf("%-6d %-12s %10.2f %10.2f %10.2f %9d %10.2f %12.2f\n", size, name, a.fps, b, b / a.fps, a.alive,
                  a.maintain_share, versus);
    }
  }
  std::printf(
      "\nstr/proc: the gRPC stream's rate over the in-process rate (goal >= 0.9); lagr/flowmap: the flow map's\n"
      "frames/s over the Lagrangian method's at the same output (the Lagrangian method's cost multiple; goal <= 2)\n");
  if (runtime.profiling())
    std::printf("\nkernel device time (SQUALL_PROFILE_KERNELS=1)\n%s",
                format_kernel_timings(runtime.kernel_timings()).c_str());
  return 0;
}

int main(int argc, char** argv) {
  return squall::bench::guarded_main(argv[0], [&] { return bench_main(argc, argv); });
}
