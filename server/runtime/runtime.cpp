#include "runtime/runtime.h"

#include <chrono>
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

Runtime::Runtime(const RuntimeOptions& options)
    : found_(select_device(options.device)),
      context_(found_.device),
      queue_(context_, found_.device),
      sources_(options.kernel_dir),
      program_prefixes_(options.program_prefixes),
      buffers_(std::make_unique<BufferPool>(context_, options.max_idle_buffer_bytes)) {
  log(LogLevel::Info, "OpenCL ", describe(found_.info));
}

void Runtime::build_programs() {
  auto start_all = std::chrono::steady_clock::now();
  for (const auto& path : sources_.programs()) {
    if (!selected(path)) continue;
    cl::Program program(context_, sources_.expanded(path));
    auto start = std::chrono::steady_clock::now();
    std::string options = sources_.build_options(path);
    try {
      program.build({found_.device}, options.c_str());
    } catch (const cl::Error&) {
      std::string build_log = program.getBuildInfo<CL_PROGRAM_BUILD_LOG>(found_.device);
      fail(Code::Internal, "kernel program " + path + " failed to build on " + found_.info.name +
                               " (options \"" + options + "\"); build log:\n" + build_log);
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

cl::Kernel Runtime::kernel(const std::string& program, const std::string& name) const {
  auto it = programs_.find(program);
  if (it == programs_.end()) fail(Code::Internal, "program " + program + " is not built");
  return cl::Kernel(it->second, name.c_str());
}

}  // namespace squall
