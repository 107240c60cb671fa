// What reading an ocean tile's fields back to the host costs: 9 float planes of n x n cells in one device
// buffer, read
//   - as the engine reads them: read_views() of a pool buffer (on a CPU device its host storage itself,
//     elsewhere one pinned block of the runtime's pool, one read command per plane);
//   - as the engine read them before: one read command per plane, into 9 vectors made for the call
//     (allocated and zero-filled);
//   - the same into 9 vectors kept from the last read (pageable memory the process has touched before);
//   - one read command for all planes into one kept vector;
//   - one read into pinned memory (a CL_MEM_ALLOC_HOST_PTR buffer mapped once, from which a GPU's DMA
//     engine copies directly);
//   - the same, then a memcpy from there into a kept vector.
// Reference: a host memcpy of the same bytes between two kept vectors. The table gives the median time of
// each over `--runs` reads and the bytes per second.
//
//   build/bench/readback_bench [--device auto|cpu|gpu|NAME] [--runs N]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include "runtime/host_transfer.h"
#include "runtime/runtime.h"
#include "bench_util.h"

using namespace squall;

namespace {

constexpr int kPlanes = 9;  // height, displacement x/y, normal x/y/z, Jacobian and its two eigenvalues

double median_seconds(const std::function<void()>& read, int runs) {
  std::vector<double> t;
  for (int r = 0; r <= runs; ++r) {  // the first run warms up
    const auto start = std::chrono::steady_clock::now();
    read();
    if (r > 0) t.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }
  std::sort(t.begin(), t.end());
  return t[t.size() / 2];
}

}  // namespace

int bench_main(int argc, char** argv) {
  RuntimeOptions options;
  options.program_prefixes = {"runtime/"};
  int runs = 51;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--device")) options.device = argv[i + 1];
    if (!std::strcmp(argv[i], "--runs")) runs = std::max(1, std::stoi(argv[i + 1]));
  }
  configure_kernel_cache();
  Runtime runtime(options);
  const cl::Context& context = runtime.context();
  std::printf("device: %s\nmedian of %d reads of %d float planes of n x n; ms and GB/s; reference: host memcpy\n\n",
              describe(runtime.device_info()).c_str(), runs, kPlanes);
  std::printf("%-10s %16s %16s %16s %16s %16s %16s %16s\n", "size", "views (engine)", "per plane, new",
              "per plane, kept", "one read, kept", "pinned", "pinned + memcpy", "memcpy (ref)");
  for (int n : {256, 512, 1024}) {
    const size_t plane = size_t(n) * n, bytes = kPlanes * plane * sizeof(float);
    std::vector<float> pattern(kPlanes * plane);
    for (size_t i = 0; i < pattern.size(); ++i) pattern[i] = float(i % 1000);
    cl::Buffer device(context, CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, bytes, pattern.data());
    cl::Buffer pinned(context, CL_MEM_READ_WRITE | CL_MEM_ALLOC_HOST_PTR, bytes);
    std::vector<FloatRange> ranges;
    for (int p = 0; p < kPlanes; ++p) ranges.push_back({p * plane, plane});
    std::vector<FloatView> views;
    auto lease = runtime.exclusive();
    write_buffer(runtime, runtime.buffers().acquire(bytes).buffer(), bytes, pattern.data());  // back to the pool
    const cl::CommandQueue& q = runtime.queue();
    auto* staging = static_cast<float*>(q.enqueueMapBuffer(pinned, CL_TRUE, CL_MAP_READ | CL_MAP_WRITE, 0, bytes));
    std::vector<std::vector<float>> kept(kPlanes, std::vector<float>(plane));
    std::vector<float> whole(kPlanes * plane), copy(kPlanes * plane);
    auto per_plane = [&](std::vector<std::vector<float>>& into, bool fresh) {
      if (fresh) into.assign(kPlanes, {});
      for (int p = 0; p < kPlanes; ++p) {
        into[p].resize(plane);
        q.enqueueReadBuffer(device, CL_FALSE, p * plane * sizeof(float), plane * sizeof(float), into[p].data());
      }
      q.finish();
    };
    std::vector<std::vector<float>> made;
    const double times[] = {
        median_seconds(
            [&] {
              views.clear();  // the pool's buffer back, to be read again
              views = read_views(runtime, runtime.buffers().acquire(bytes), ranges);
            },
            runs),
        median_seconds([&] { per_plane(made, true); }, runs),
        median_seconds([&] { per_plane(kept, false); }, runs),
        median_seconds([&] { q.enqueueReadBuffer(device, CL_TRUE, 0, bytes, whole.data()); }, runs),
        median_seconds([&] { q.enqueueReadBuffer(device, CL_TRUE, 0, bytes, staging); }, runs),
        median_seconds(
            [&] {
              q.enqueueReadBuffer(device, CL_TRUE, 0, bytes, staging);
              std::memcpy(copy.data(), staging, bytes);
            },
            runs),
        median_seconds([&] { std::memcpy(copy.data(), whole.data(), bytes); }, runs),
    };
    const bool views_differ = !std::equal(views.back().begin(), views.back().end(), pattern.end() - plane);
    if (std::memcmp(staging, pattern.data(), bytes) != 0 || made[kPlanes - 1] != kept[kPlanes - 1] || views_differ)
      std::printf("(a read differs from what the device holds)\n");
    q.enqueueUnmapMemObject(pinned, staging);
    q.finish();
    char size[16];
    std::snprintf(size, sizeof(size), "%dx%d", n, n);
    std::printf("%-10s", size);
    for (double t : times) std::printf(" %7.3f %5.1fGB/s", 1e3 * t, double(bytes) / t / 1e9);
    std::printf("\n");
  }
  return 0;
}

int main(int argc, char** argv) {
  return squall::bench::guarded_main(argv[0], [&] { return bench_main(argc, argv); });
}
