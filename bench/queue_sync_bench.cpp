// What one wait for the device costs: a small kernel enqueued without waiting (the reference), the same
// kernel followed by clFinish, a blocking map and unmap, a blocking read of 64 bytes, and clFinish on an
// empty queue. Each is repeated `--calls` times in a row; the table gives the median over `--runs` of the
// wall time and the process's CPU time (all threads: the device's workers too) per call, and the ratio of
// each to the reference. On PoCL's CPU device a wait hands the command to a worker thread and wakes the
// caller when it is done, so its CPU time is what a request pays per blocking call.
//
//   build/bench/queue_sync_bench [--device auto|cpu|gpu|NAME] [--runs N] [--calls N]
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include "runtime/kernel.h"
#include "runtime/runtime.h"
#include "bench_util.h"

using namespace squall;

namespace {

double process_cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

struct PerCall {
  double wall_us = 0, cpu_us = 0;
};

// Median wall and CPU time per call of `call`, run `calls` times in a row, over `runs` runs.
PerCall median_per_call(const cl::CommandQueue& queue, const std::function<void()>& call, int runs, int calls) {
  std::vector<double> wall, cpu;
  for (int r = 0; r <= runs; ++r) {  // the first run warms up
    queue.finish();
    const auto start = std::chrono::steady_clock::now();
    const double cpu_start = process_cpu_seconds();
    for (int i = 0; i < calls; ++i) call();
    queue.finish();
    if (r == 0) continue;
    wall.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    cpu.push_back(process_cpu_seconds() - cpu_start);
  }
  std::sort(wall.begin(), wall.end());
  std::sort(cpu.begin(), cpu.end());
  return {1e6 * wall[wall.size() / 2] / calls, 1e6 * cpu[cpu.size() / 2] / calls};
}

}  // namespace

int bench_main(int argc, char** argv) {
  RuntimeOptions options;
  options.program_prefixes = {"runtime/"};
  int runs = 7, calls = 2000;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--device")) options.device = argv[i + 1];
    if (!std::strcmp(argv[i], "--runs")) runs = std::stoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--calls")) calls = std::stoi(argv[i + 1]);
  }
  configure_kernel_cache();
  Runtime runtime(options);
  runtime.build_programs();
  Kernel<cl::Buffer, cl_float, cl_int> fill(runtime, "runtime/selftest.cl", "fill");
  constexpr int n = 256;  // one work-group
  BufferLease buffer = runtime.buffers().acquire(n * sizeof(float));
  float host[16];
  auto lease = runtime.exclusive();
  const cl::CommandQueue& q = runtime.queue();
  auto launch = [&] { fill.launch(cl::NDRange(n), cl::NDRange(n), buffer.buffer(), cl_float(1), cl_int(n)); };

  const std::vector<std::pair<std::string, std::function<void()>>> cases = {
      {"kernel, no wait", launch},
      {"kernel + clFinish",
       [&] {
         launch();
         q.finish();
       }},
      {"blocking map + unmap",
       [&] {
         void* p = q.enqueueMapBuffer(buffer.buffer(), CL_TRUE, CL_MAP_READ | CL_MAP_WRITE, 0, sizeof(host));
         q.enqueueUnmapMemObject(buffer.buffer(), p);
       }},
      {"blocking read, 64 B", [&] { q.enqueueReadBuffer(buffer.buffer(), CL_TRUE, 0, sizeof(host), host); }},
      {"clFinish, empty queue", [&] { q.finish(); }},
  };
  std::printf(
      "device: %s\nmedian of %d runs of %d calls in a row; per call: wall and process CPU time (all "
      "threads); reference: the kernel with no wait\n\n%-24s %10s %10s %10s %10s\n",
      describe(runtime.device_info()).c_str(), runs, calls, "call", "wall us", "cpu us", "wall/ref", "cpu/ref");
  PerCall reference;
  for (const auto& [name, call] : cases) {
    const PerCall t = median_per_call(q, call, runs, calls);
    if (name == cases.front().first) reference = t;
    std::printf("%-24s %10.1f %10.1f %10.1f %10.1f\n", name.c_str(), t.wall_us, t.cpu_us,
                t.wall_us / std::max(reference.wall_us, 1e-3), t.cpu_us / std::max(reference.cpu_us, 1e-3));
  }
  return 0;
}

int main(int argc, char** argv) {
  return squall::bench::guarded_main(argv[0], [&] { return bench_main(argc, argv); });
}
