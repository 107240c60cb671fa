#include "runtime/runtime.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sstream>

#include "common/error.h"
#include "common/log.h"

namespace squall {

std::string configure_kernel_cache(const std::string& dir) {
  if (const char* set = std::getenv("POCL_CACHE_DIR"); set && *set && dir.empty()) return set;
  std::string path = dir;
  if (path.empty()) {
    const char* xdg = std::getenv("XDG_CACHE_HOME");
    const char* home = std::getenv("HOME");
    path = xdg && *xdg ? std::string(xdg) + "/squall/pocl"
                       : std::string(home && *home ? home : "/tmp") + "/.cache/squall/pocl";
  }
  std::error_code ec;
  std::filesystem::create_directories(path, ec);
  if (ec) log(LogLevel::Warn, "cannot create kernel cache ", path, ": ", ec.message());
  setenv("POCL_CACHE_DIR", path.c_str(), 1);
  return path;
}

namespace {

bool profile_from_environment() {
  const char* value = std::getenv("SQUALL_PROFILE_KERNELS");
  return value && std::string(value) == "1";
}

// The device computes in its pool buffers' host storage when what the host writes there is what a copy
// on the device reads, and what the copy writes lands in the other buffer's storage.
bool probe_host_storage(BufferPool& pool, const cl::CommandQueue& queue) {
  constexpr size_t kBytes = 256;
  const BufferLease from = pool.acquire(kBytes), to = pool.acquire(kBytes);
  auto* written = static_cast<unsigned char*>(host_storage(from.buffer()));
  const auto* copied = static_cast<const unsigned char*>(host_storage(to.buffer()));
  if (!written || !copied) return false;
  for (size_t i = 0; i < kBytes; ++i) written[i] = static_cast<unsigned char>(i * 7 + 1);
  queue.enqueueCopyBuffer(from.buffer(), to.buffer(), 0, 0, kBytes);
  queue.finish();
  return std::equal(written, written + kBytes, copied);
}

}  // namespace

Runtime::Runtime(const RuntimeOptions& options)
    : profiling_(options.profile_kernels || profile_from_environment()),
      found_(select_device(options.device)),
      context_(found_.device),
      sources_(options.kernel_dir),
      program_prefixes_(options.program_prefixes),
      buffers_(std::make_unique<BufferPool>(context_, options.max_idle_buffer_bytes,
                                            found_.info.type == "cpu" && options.host_buffers_on_cpu, held_queue_slot)),
      queues_(std::make_unique<QueueSlots>(context_, found_.device, options.queues,
                                           profiling_ ? CL_QUEUE_PROFILING_ENABLE : 0,
                                           [this](size_t slot) { buffers_->settle(int(slot)); })) {
  log(LogLevel::Info, "OpenCL ", describe(found_.info), ", ", queues_->count(), " queue(s)");
  computes_in_host_storage_ = probe_host_storage(*buffers_, queues_->queue(0));
  log(LogLevel::Info, computes_in_host_storage_ ? "buffers: the device computes in their host memory"
                                                : "buffers: read and written by commands");
  if (found_.info.type == "cpu" && options.host_buffers_on_cpu && !computes_in_host_storage_)
    log(LogLevel::Warn,
        "the device keeps copies of host-memory buffers: out of place, an FFTW transform runs as "
        "two native kernels");
  if (profiling_) log(LogLevel::Info, "kernel profiling on: each kernel launch waits for its device time");
}

void Runtime::build_programs() {
  auto start_all = std::chrono::steady_clock::now();
  for (const auto& path : sources_.programs()) {
    if (!selected(path)) continue;
    cl::Program program(context_, sources_.expanded(path));
    auto start = std::chrono::steady_clock::now();
    // Argument info lets Kernel<...> check each argument's type against the host's declaration.
    std::string options = sources_.build_options(path) + " -cl-kernel-arg-info";
    try {
      program.build({found_.device}, options.c_str());
    } catch (const cl::Error&) {
      std::string build_log = program.getBuildInfo<CL_PROGRAM_BUILD_LOG>(found_.device);
      fail(Code::Internal, "kernel program " + path + " failed to build on " + found_.info.name + " (options \"" +
                               options + "\"); build log:\n" + build_log);
    }
    ProgramBuild build;
    build.program = path;
    build.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::vector<cl::Kernel> kernels;
    program.createKernels(&kernels);
    for (const auto& k : kernels) build.kernels.push_back(k.getInfo<CL_KERNEL_FUNCTION_NAME>());
    log(LogLevel::Info, "built ", path, " (", build.kernels.size(), " kernels) in ", build.seconds, " s");
    builds_.push_back(std::move(build));
    programs_.emplace(path, std::move(program));
  }
  built_ = true;
  log(LogLevel::Info, "built ", builds_.size(), " programs in ",
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_all).count(), " s");
}

bool Runtime::selected(const std::string& program) const {
  if (program_prefixes_.empty()) return true;
  for (const auto& prefix : program_prefixes_)
    if (program.rfind(prefix, 0) == 0) return true;
  return false;
}

void Runtime::record_kernel_time(const std::string& program, const std::string& kernel, uint64_t device_ns) {
  std::lock_guard<std::mutex> guard(timings_mutex_);
  KernelTiming& t = timings_[{program, kernel}];
  t.program = program;
  t.kernel = kernel;
  ++t.launches;
  t.device_ns += device_ns;
}

std::vector<KernelTiming> Runtime::kernel_timings() const {
  std::lock_guard<std::mutex> guard(timings_mutex_);
  std::vector<KernelTiming> out;
  for (const auto& [key, timing] : timings_) out.push_back(timing);
  return out;
}

std::string format_kernel_timings(const std::vector<KernelTiming>& timings) {
  std::vector<KernelTiming> sorted = timings;
  std::sort(sorted.begin(), sorted.end(), [](const auto& a, const auto& b) { return a.device_ns > b.device_ns; });
  double total_ns = 0;
  for (const auto& t : sorted) total_ns += double(t.device_ns);
  std::ostringstream out;
  char line[256];
  std::snprintf(line, sizeof(line), "%-22s %-26s %9s %12s %12s %7s\n", "program", "kernel", "launches", "total ms",
                "mean us", "share");
  out << line;
  for (const auto& t : sorted) {
    double ns = double(t.device_ns);
    std::snprintf(line, sizeof(line), "%-22s %-26s %9llu %12.3f %12.3f %6.1f%%\n", t.program.c_str(), t.kernel.c_str(),
                  (unsigned long long)t.launches, ns * 1e-6, ns * 1e-3 / double(t.launches),
                  total_ns > 0 ? 100 * ns / total_ns : 0.0);
    out << line;
  }
  return out.str();
}

cl::Kernel Runtime::kernel(const std::string& program, const std::string& name) const {
  auto it = programs_.find(program);
  if (it == programs_.end()) fail(Code::Internal, "program " + program + " is not built");
  return cl::Kernel(it->second, name.c_str());
}

}  // namespace squall
