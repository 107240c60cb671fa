// eWave steps per second at 256^2, 512^2, 1024^2 and 1400x600 (the grid of the demonstration in sec. 5 of
// J. Tessendorf, "Gilligan: A Prototype Framework for Simulating and Rendering Maritime Environments" (2017)),
// in one run:
//   (a) in process: EWaveSession::step on this machine's device, height read back each step;
//   (b) through squall.v1.EWave/Run against a squalld (--address), pipelined, height returned each step;
//   (c) an FFTW reference of the spectral core of the same step on the host (fftw3f, 2 threads): R2C of
//       h and phi, the per-mode propagator (Gilligan eq 64-65), C2R of h and phi.
// Prints steps/s and the ratios (a)/(c) and (b)/(a).
//
//   build/bench/ewave_bench [--device auto|cpu|gpu|NAME] [--fft auto|vkfft|clfft|fftw] [--address HOST:PORT] [--seconds S]
//                     [--grid NXxNY (one grid instead of the four)]
//                     [--kernel-dir DIR (kernels from DIR, e.g. another commit's, not the embedded ones)]
#include <fftw3.h>
#include <grpcpp/grpcpp.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <functional>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "bench_util.h"
#include "ewave/ewave_session.h"
#include "ewave/propagator.h"
#include "fft/fft.h"
#include "runtime/runtime.h"
#include "squall/v1/ewave.grpc.pb.h"

using namespace squall;
using Clock = std::chrono::steady_clock;

namespace {

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

ewave::EWaveConfig config(size_t nx, size_t ny) {
  ewave::EWaveConfig c;
  c.nx = int64_t(nx), c.ny = int64_t(ny), c.dx = c.dy = 0.01;
  c.source_scale = 1.0;
  return c;
}

// The step the benchmark runs everywhere: a moving ellipse hull (obstruction + source), trim, height out.
ewave::StepInputs inputs(const ewave::EWaveConfig& c, int n) {
  ewave::StepInputs in;
  in.dt = 0.02;
  in.outputs = {true, false, false, false};
  in.shapes = {
      ewave::Shape{ewave::ShapeKind::Ellipse, 0.1 * c.length_x() + 0.005 * n, 0.5 * c.length_y(), 0.12, 0.04, 0, {}}};
  return in;
}

// Steps/s of a timed loop: at least 3 steps and `budget` seconds (after one warm-up step).
double rate(const std::function<void(int)>& step, double budget) {
  step(0);
  int n = 0;
  auto start = Clock::now();
  while (n < 3 || seconds_since(start) < budget) step(++n);
  return n / seconds_since(start);
}

double in_process(Runtime& runtime, fft::Fft& fft, const ewave::EWaveConfig& c, double budget) {
  ewave::EWaveSession session(runtime, fft, c);
  return rate([&](int n) { session.step(inputs(c, n)); }, budget);
}

// The spectral core of one step with FFTW on the host, in float like the device path.
double fftw_reference(const ewave::EWaveConfig& c, double budget) {
  const int nx = int(c.nx), ny = int(c.ny), half = nx / 2 + 1;
  const size_t cells = size_t(nx) * ny, modes = size_t(half) * ny;
  float* real = fftwf_alloc_real(2 * cells);
  fftwf_complex* spectrum = fftwf_alloc_complex(2 * modes);
  int dims[2] = {ny, nx};  // row-major, x fastest
  fftwf_plan forward =
      fftwf_plan_many_dft_r2c(2, dims, 2, real, nullptr, 1, int(cells), spectrum, nullptr, 1, int(modes), FFTW_MEASURE);
  fftwf_plan inverse =
      fftwf_plan_many_dft_c2r(2, dims, 2, spectrum, nullptr, 1, int(modes), real, nullptr, 1, int(cells), FFTW_MEASURE);
  std::vector<double> table = ewave::propagator_coefficients(c, 0.02);
  std::vector<float> p(table.begin(), table.end());
  std::mt19937 rng(1);
  for (size_t i = 0; i < 2 * cells; ++i) real[i] = std::uniform_real_distribution<float>(-1e-3f, 1e-3f)(rng);
  double steps = rate(
      [&](int) {
        fftwf_execute(forward);
        fftwf_complex* h = spectrum;
        fftwf_complex* phi = spectrum + modes;
        for (size_t m = 0; m < modes; ++m) {
          const float cs = p[4 * m], a = p[4 * m + 1], b = p[4 * m + 2];
          for (int part = 0; part < 2; ++part) {
            const float hv = h[m][part], pv = phi[m][part];
            h[m][part] = cs * hv + a * pv;
            phi[m][part] = cs * pv - b * hv;
          }
        }
        fftwf_execute(inverse);
      },
      budget);
  fftwf_destroy_plan(forward);
  fftwf_destroy_plan(inverse);
  fftwf_free(real);
  fftwf_free(spectrum);
  return steps;
}

squall::v1::EWaveStepRequest proto_step(const std::string& id, const ewave::EWaveConfig& c, int n) {
  ewave::StepInputs in = inputs(c, n);
  squall::v1::EWaveStepRequest r;
  r.set_session_id(id);
  r.mutable_inputs()->set_dt(in.dt);
  r.mutable_inputs()->add_outputs(squall::v1::EWAVE_OUTPUT_HEIGHT);
  auto* e = r.mutable_inputs()->add_shapes()->mutable_ellipse();
  const auto& s = in.shapes[0];
  e->set_center_x(s.x), e->set_center_y(s.y), e->set_semi_axis_a(s.a), e->set_semi_axis_b(s.b);
  return r;
}

// Steps through one Run stream, a writer thread sending while this thread reads; returns steps/s.
double run_stream(squall::v1::EWave::Stub& stub, const std::string& id, const ewave::EWaveConfig& c, int steps) {
  grpc::ClientContext context;
  auto call = stub.Run(&context);
  auto start = Clock::now();
  std::thread writer([&] {
    for (int n = 0; n < steps && call->Write(proto_step(id, c, n)); ++n) {
    }
    call->WritesDone();
  });
  squall::v1::EWaveFrame frame;
  int read = 0;
  while (call->Read(&frame)) ++read;
  double elapsed = seconds_since(start);
  writer.join();
  grpc::Status status = call->Finish();
  if (!status.ok() || read != steps) {
    std::fprintf(stderr, "Run failed: %s (%d of %d frames)\n", status.error_message().c_str(), read, steps);
    return 0;
  }
  return steps / elapsed;
}

double through_stream(const std::string& address, const ewave::EWaveConfig& c, double expected_rate, double budget) {
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(-1);  // a 1024^2 frame is just over gRPC's 4 MiB default
  auto stub = squall::v1::EWave::NewStub(grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), args));
  grpc::ClientContext create_context;
  squall::v1::EWaveCreateSessionRequest create;
  auto* pc = create.mutable_config();
  pc->set_nx(uint32_t(c.nx)), pc->set_ny(uint32_t(c.ny)), pc->set_dx(c.dx), pc->set_dy(c.dy);
  pc->set_source_scale(c.source_scale);
  squall::v1::EWaveSessionResponse session;
  grpc::Status status = stub->CreateSession(&create_context, create, &session);
  if (!status.ok()) {
    std::fprintf(stderr, "CreateSession failed: %s\n", status.error_message().c_str());
    return 0;
  }
  run_stream(*stub, session.session_id(), c, 2);  // warm-up: plans and tables of this size
  const int steps = std::max(3, int(expected_rate * budget));
  double r = run_stream(*stub, session.session_id(), c, steps);
  grpc::ClientContext close_context;
  squall::v1::EWaveSessionRequest close;
  close.set_session_id(session.session_id());
  squall::v1::EWaveCloseResponse closed;
  stub->CloseSession(&close_context, close, &closed);
  return r;
}

}  // namespace

int bench_main(int argc, char** argv) {
  RuntimeOptions options;
  options.program_prefixes = {"runtime/", "ewave/"};
  std::string backend = "auto", address;
  double budget = 3;
  std::vector<std::pair<size_t, size_t>> sizes = {{256, 256}, {512, 512}, {1024, 1024}, {1400, 600}};
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--device")) options.device = argv[i + 1];
    if (!std::strcmp(argv[i], "--fft")) backend = argv[i + 1];
    if (!std::strcmp(argv[i], "--address")) address = argv[i + 1];
    if (!std::strcmp(argv[i], "--seconds")) budget = std::stod(argv[i + 1]);
    if (!std::strcmp(argv[i], "--kernel-dir")) options.kernel_dir = argv[i + 1];  // other kernels, same host code
    size_t nx = 0, ny = 0;
    if (!std::strcmp(argv[i], "--grid") && std::sscanf(argv[i + 1], "%zux%zu", &nx, &ny) == 2) sizes = {{nx, ny}};
  }
  configure_kernel_cache();
  Runtime runtime(options);
  runtime.build_programs();
  std::string why;
  backend = fft::chosen_backend(runtime, backend, &why);  // as squalld chooses it
  fft::Fft fft(fft::make_backend(runtime, backend));
  fftwf_init_threads();
  fftwf_plan_with_nthreads(2);

  std::printf("device: %s, fft %s (%s); squalld: %s\n", describe(runtime.device_info()).c_str(), backend.c_str(),
              why.c_str(), address.empty() ? "none (--address not given)" : address.c_str());
  std::printf("steps/s of one eWave step (moving hull, trim, height returned); >= %.0f s per cell\n\n", budget);
  std::printf("%-10s %12s %12s %12s %14s %14s\n", "grid", "in-process", "Run stream", "fftw ref", "process/fftw",
              "stream/process");
  double steps_1024 = -1;  // not measured unless the grids include 1024x1024
  for (auto [nx, ny] : sizes) {
    ewave::EWaveConfig c = config(nx, ny);
    double a = in_process(runtime, fft, c, budget);
    double b = address.empty() ? 0 : through_stream(address, c, a, budget);
    double f = fftw_reference(c, budget);
    std::printf("%4zux%-5zu %12.2f %12.2f %12.2f %14.2f %14.2f\n", nx, ny, a, b, f, a / f, b / a);
    if (nx == 1024 && ny == 1024) steps_1024 = a;
  }
  std::printf(
      "\nratios: process/fftw > 1 means the device step is faster than the FFTW core on this host;\n"
      "stream/process < 1 is the cost of gRPC (serialization, loopback transfer of the height field)\n");
  if (steps_1024 >= 0) bench::print_gpu_goal("eWave 1024x1024 in process", steps_1024, 500, "steps/s");
  if (runtime.profiling())  // SQUALL_PROFILE_KERNELS=1: device time per kernel (launches wait: rates drop)
    std::printf("\nkernel device time (SQUALL_PROFILE_KERNELS=1)\n%s",
                format_kernel_timings(runtime.kernel_timings()).c_str());
  fftwf_cleanup_threads();
  return 0;
}

int main(int argc, char** argv) {
  return squall::bench::guarded_main(argv[0], [&] { return bench_main(argc, argv); });
}
