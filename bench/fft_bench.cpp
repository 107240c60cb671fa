// One complex 2D FFT (forward, single precision, in place) with each backend the device offers (VkFFT,
// clFFT, and on a CPU device the fftw backend, FFTW in a native kernel on the OpenCL buffer) and with plain
// FFTW on host arrays (2 threads, the reference; and 1 thread) at 256^2, 512^2 and 1024^2 on this machine,
// in one run; prints medians, the ratios to the reference and the reference's time over one thread's
// (what a second thread gains: 0.5 at best).
//
//   build/bench/fft_bench [--device auto|cpu|gpu|NAME] [--runs N]
#include <fftw3.h>

#include <cstdio>
#include <cstring>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "bench_util.h"
#include "fft/fft.h"
#include "runtime/runtime.h"

using namespace squall;

int bench_main(int argc, char** argv) {
  RuntimeOptions options;
  int runs = 21;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--device")) options.device = argv[i + 1];
    if (!std::strcmp(argv[i], "--runs")) runs = std::stoi(argv[i + 1]);
  }
  configure_kernel_cache();
  Runtime runtime(options);
  fftwf_init_threads();
  std::vector<std::string> names = fft::available_backends(runtime);
  std::vector<std::unique_ptr<fft::Fft>> backends;
  for (const auto& name : names) backends.push_back(std::make_unique<fft::Fft>(fft::make_backend(runtime, name)));

  std::printf(
      "device: %s\nmedian of %d runs, one forward C2C transform, f32, in place; reference: FFTW on host "
      "arrays, 2 threads (and 1)\n\n%-10s",
      describe(runtime.device_info()).c_str(), runs, "size");
  for (const auto& name : names) std::printf(" %10s ms", name.c_str());
  std::printf(" %10s ms %10s ms", "reference", "1 thread");
  for (const auto& name : names) std::printf(" %10s/ref", name.c_str());
  std::printf(" %14s", "ref/1 thread");
  std::printf("\n");
  for (size_t n : {256, 512, 1024}) {
    fft::PlanKey key{n, n, 1, fft::Transform::C2C, fft::Precision::F32};
    std::vector<float> host(2 * n * n);
    std::mt19937 rng(1);
    for (auto& v : host) v = std::uniform_real_distribution<float>(-1, 1)(rng);
    auto lease = runtime.buffers().acquire(host.size() * 4);  // as the engines allocate
    runtime.queue().enqueueWriteBuffer(lease.buffer(), CL_TRUE, 0, host.size() * 4, host.data());
    std::vector<double> times;
    for (auto& f : backends) {
      fft::Plan& plan = f->plan(key);
      times.push_back(bench::median_seconds(
          [&] {
            plan.enqueue(runtime.queue(), fft::Direction::Forward, lease.buffer(), lease.buffer());
            runtime.queue().finish();
          },
          runs));
    }
    auto* buf = reinterpret_cast<fftwf_complex*>(host.data());
    auto fftw_seconds = [&](int threads) {
      fftwf_plan_with_nthreads(threads);
      fftwf_plan plan = fftwf_plan_dft_2d(int(n), int(n), buf, buf, FFTW_FORWARD, FFTW_MEASURE);
      double t = bench::median_seconds([&] { fftwf_execute(plan); }, runs);
      fftwf_destroy_plan(plan);
      return t;
    };
    const double t_fftw = fftw_seconds(2), t_one = fftw_seconds(1);
    std::printf("%4zux%-5zu", n, n);
    for (double t : times) std::printf(" %13.3f", t * 1e3);
    std::printf(" %13.3f %13.3f", t_fftw * 1e3, t_one * 1e3);
    for (double t : times) std::printf(" %14.2f", t / t_fftw);
    std::printf(" %14.2f", t_fftw / t_one);
    std::printf("\n");
    std::fflush(stdout);
  }
  std::printf("\nratios > 1: slower than FFTW on the same machine\n");
  fftwf_cleanup_threads();
  return 0;
}

int main(int argc, char** argv) {
  return squall::bench::guarded_main(argv[0], [&] { return bench_main(argc, argv); });
}
