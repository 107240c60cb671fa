// One complex 2D FFT (forward, single precision, in place) with VkFFT, clFFT and FFTW (2 threads) at
// 256^2, 512^2 and 1024^2 on this machine, in one run; prints medians and the ratios to FFTW.
//
//   build/bench/fft_bench [--device auto|cpu|gpu|NAME] [--runs N]
#include <fftw3.h>

#include <cstdio>
#include <cstring>
#include <random>
#include <string>

#include "bench_util.h"
#include "fft/fft.h"
#include "runtime/runtime.h"

using namespace squall;

int main(int argc, char** argv) {
  RuntimeOptions options;
  int runs = 21;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--device")) options.device = argv[i + 1];
    if (!std::strcmp(argv[i], "--runs")) runs = std::stoi(argv[i + 1]);
  }
  configure_kernel_cache();
  Runtime runtime(options);
  fftwf_init_threads();
  fftwf_plan_with_nthreads(2);
  fft::Fft vkfft(fft::make_vkfft(runtime)), clfft(fft::make_clfft(runtime));

  std::printf("device: %s\nmedian of %d runs, one forward C2C transform, f32, in place\n\n",
              describe(runtime.device_info()).c_str(), runs);
  std::printf("%-10s %12s %12s %12s %14s %14s\n", "size", "vkfft ms", "clfft ms", "fftw ms", "vkfft/fftw",
              "clfft/fftw");
  for (size_t n : {256, 512, 1024}) {
    fft::PlanKey key{n, n, 1, fft::Transform::C2C, fft::Precision::F32};
    std::vector<float> host(2 * n * n);
    std::mt19937 rng(1);
    for (auto& v : host) v = std::uniform_real_distribution<float>(-1, 1)(rng);
    cl::Buffer data(runtime.context(), CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, host.size() * 4, host.data());
    auto device_time = [&](fft::Fft& f) {
      fft::Plan& plan = f.plan(key);
      return bench::median_seconds(
          [&] {
            plan.enqueue(runtime.queue(), fft::Direction::Forward, data, data);
            runtime.queue().finish();
          },
          runs);
    };
    double t_vk = device_time(vkfft), t_cl = device_time(clfft);
    auto* buf = reinterpret_cast<fftwf_complex*>(host.data());
    fftwf_plan plan = fftwf_plan_dft_2d(int(n), int(n), buf, buf, FFTW_FORWARD, FFTW_MEASURE);
    double t_fftw = bench::median_seconds([&] { fftwf_execute(plan); }, runs);
    fftwf_destroy_plan(plan);
    std::printf("%4zux%-5zu %12.3f %12.3f %12.3f %14.2f %14.2f\n", n, n, t_vk * 1e3, t_cl * 1e3, t_fftw * 1e3,
                t_vk / t_fftw, t_cl / t_fftw);
  }
  std::printf("\nratios > 1: slower than FFTW on the same machine\n");
  fftwf_cleanup_threads();
  return 0;
}
