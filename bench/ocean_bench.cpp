// Ocean tiles per second at 256^2, 512^2 and 1024^2 with height, displacement, normals and Jacobian
// (9 float32 fields), (a) the OceanEngine in process, (b) the same engine through a localhost gRPC
// StreamTiles call (an in-process grpc::Server with the daemon's OceanService, client reassembling the
// frames), (c) the FFTW double-precision reference (server/ocean/cpu_reference.h) doing the same math on
// N threads; prints the table and the ratios (goals: b/a >= 0.9, a/c >= 0.3).
//
// --layers L sums L such layers, the first of 1 km and each next one 9.7 times smaller (incommensurate
// extents, as layered oceans use to hide their periods), all on the first one's grid.
//
//   build/bench/ocean_bench [--device auto|cpu|gpu|NAME] [--fft auto|vkfft|clfft|fftw] [--seconds S] [--threads N]
//                           [--layers L] [--kernel-dir DIR (kernels from DIR, e.g. another commit's, not the
//                           embedded ones)]
#include <grpcpp/grpcpp.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>

#include "bench_util.h"
#include "client/ocean_frames.h"
#include "rpc/capability.h"
#include "rpc/serving.h"
#include "ocean/cpu_reference.h"
#include "ocean/ocean_engine.h"
#include "ocean/ocean_request.h"
#include "ocean/ocean_service.h"
#include "ocean/shared_engine.h"

using namespace squall;
namespace v1 = squall::v1;

namespace {

using Clock = std::chrono::steady_clock;
constexpr unsigned kOutputs = ocean::Height | ocean::Displacement | ocean::Normals | ocean::Jacobian;
const v1::TileOutput kFields[] = {
    v1::TILE_OUTPUT_HEIGHT,   v1::TILE_OUTPUT_DISPLACEMENT_X, v1::TILE_OUTPUT_DISPLACEMENT_Y,
    v1::TILE_OUTPUT_NORMAL_X, v1::TILE_OUTPUT_NORMAL_Y,       v1::TILE_OUTPUT_NORMAL_Z,
    v1::TILE_OUTPUT_JACOBIAN, v1::TILE_OUTPUT_JACOBIAN_MINUS, v1::TILE_OUTPUT_JACOBIAN_PLUS};

// `layers` JONSWAP layers with n x n cells, of 1 km, 1 km / 9.7, ..., choppy.
v1::TileSpec tile(int n, int layers) {
  v1::TileSpec t;
  double extent = 1000;
  for (int a = 0; a < layers; ++a, extent /= 9.7) {
    auto* l = t.add_layers();
    l->set_extent_x(extent), l->set_extent_y(extent), l->set_nx(n), l->set_ny(n);
    l->set_spectrum(v1::SPECTRUM_MODEL_JONSWAP), l->set_spreading(v1::SPREADING_MODEL_MITSUYASU);
    l->set_dispersion(v1::DISPERSION_MODEL_DEEP), l->set_wind_speed(12), l->set_fetch(100000), l->set_seed(1);
  }
  t.set_choppiness(1);
  return t;
}

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

// Frames per second of `frame(i)` over at least `budget` seconds and 3 frames, after one warm-up frame
// (which builds the h0 spectrum and the FFT plans).
template <typename Frame>
double rate(Frame&& frame, double budget) {
  frame(0);
  auto start = Clock::now();
  int frames = 0;
  while (frames < 3 || seconds_since(start) < budget) frame(++frames);
  return frames / seconds_since(start);
}

// Frames per second of one StreamTiles call of `frames` frames, timed from the call to the last frame
// reassembled on the client.
double stream_rate(v1::Ocean::Stub& stub, const v1::TileSpec& spec, int frames) {
  v1::StreamTilesRequest request;
  *request.mutable_tile() = spec;
  request.mutable_t0()->set_seconds(0);
  request.set_dt(1.0 / 30);
  request.set_frame_count(frames);
  for (auto f : kFields) request.add_outputs(f);
  grpc::ClientContext context;
  auto start = Clock::now();
  auto reader = stub.StreamTiles(&context, request);
  client::ocean::FrameAssembler assembler;
  v1::TileChunk chunk;
  int got = 0;
  while (reader->Read(&chunk)) got += assembler.add(chunk).has_value();
  double elapsed = seconds_since(start);
  grpc::Status status = reader->Finish();
  if (!status.ok() || got != frames) {
    std::fprintf(stderr, "stream failed: %s (%d of %d frames)\n", status.error_message().c_str(), got, frames);
    std::exit(1);
  }
  return frames / elapsed;
}

}  // namespace

int bench_main(int argc, char** argv) {
  RuntimeOptions options;
  std::string backend = "auto";
  double budget = 3;
  int threads = 2, layers = 1;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--device")) options.device = argv[i + 1];
    if (!std::strcmp(argv[i], "--fft")) backend = argv[i + 1];
    if (!std::strcmp(argv[i], "--seconds")) budget = std::stod(argv[i + 1]);
    if (!std::strcmp(argv[i], "--threads")) threads = std::stoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--layers")) layers = std::max(1, std::stoi(argv[i + 1]));
    if (!std::strcmp(argv[i], "--kernel-dir")) options.kernel_dir = argv[i + 1];  // other kernels, same host code
  }
  configure_kernel_cache();
  Runtime runtime(options);
  runtime.build_programs();
  std::string why;
  backend = fft::chosen_backend(runtime, backend, &why);  // as squalld chooses it
  fft::Fft fft(fft::make_backend(runtime, backend));
  rpc::ServingState serving{Limits{}};
  rpc::EngineContext engines(runtime, fft, serving.gate(), SessionPolicy{});
  rpc::OceanService service(serving);
  service.start(engines);  // the service and the in-process loop share this one engine
  ocean::OceanEngine& engine = ocean::shared_engine(engines);
  serving.set_phase(rpc::ServingState::Phase::Serving);

  grpc::ServerBuilder builder;
  int port = 0;
  builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
  builder.RegisterService(&service);
  builder.SetMaxSendMessageSize(int(serving.gate().limits().max_message_bytes));
  std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(-1);
  auto stub = v1::Ocean::NewStub(
      grpc::CreateCustomChannel("127.0.0.1:" + std::to_string(port), grpc::InsecureChannelCredentials(), args));
  ocean::CpuReference reference(threads);

  std::printf("device: %s, FFT %s (%s); FFTW reference on %d threads\n", describe(runtime.device_info()).c_str(),
              backend.c_str(), why.c_str(), threads);
  std::printf("%d JONSWAP layer(s), outputs height + displacement + normals + Jacobian (9 float32 fields)\n\n", layers);
  std::printf("%-10s %14s %14s %14s %12s %12s\n", "size", "in-process/s", "grpc stream/s", "fftw ref/s", "stream/in",
              "engine/fftw");
  double tiles_512 = 0;
  for (int n : {256, 512, 1024}) {
    v1::TileSpec proto = tile(n, layers);
    ocean::TileSpec spec = ocean::rpc::tile_spec(proto, serving.gate());
    double in_process = rate([&](int i) { engine.tile(spec, i / 30.0, kOutputs); }, budget);
    int frames = std::max(3, int(in_process * budget));
    stream_rate(*stub, proto, 1);  // warm-up: connection, buffers
    double streamed = stream_rate(*stub, proto, frames);
    double fftw = rate([&](int i) { reference.tile(spec, i / 30.0, kOutputs); }, budget);
    std::printf("%4dx%-5d %14.2f %14.2f %14.2f %12.2f %12.2f\n", n, n, in_process, streamed, fftw,
                streamed / in_process, in_process / fftw);
    if (n == 512) tiles_512 = in_process;
    std::fflush(stdout);
  }
  std::printf("\ngoals: stream/in >= 0.9, engine/fftw >= 0.3\n");
  if (layers == 1) bench::print_gpu_goal("ocean 512x512 in process (9 fields)", tiles_512, 2000, "tiles/s");
  if (runtime.profiling())  // SQUALL_PROFILE_KERNELS=1: device time per kernel (launches wait: rates drop)
    std::printf("\nkernel device time (SQUALL_PROFILE_KERNELS=1)\n%s",
                format_kernel_timings(runtime.kernel_timings()).c_str());
  server->Shutdown();
  return 0;
}

int main(int argc, char** argv) {
  return squall::bench::guarded_main(argv[0], [&] { return bench_main(argc, argv); });
}
