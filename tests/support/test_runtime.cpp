#include "support/test_runtime.h"

#include <cstdlib>
#include <map>
#include <memory>
#include <string>

namespace squall::test {

std::vector<std::string> programs_under_test() {
  std::vector<std::string> prefixes;
  std::string list = SQUALL_TEST_PROGRAMS;  // from squall_test(... PROGRAMS ...), ','-separated
  for (size_t start = 0; start < list.size();) {
    size_t end = list.find(',', start);
    if (end == std::string::npos) end = list.size();
    if (end > start) prefixes.push_back(list.substr(start, end - start));
    start = end + 1;
  }
  return prefixes;
}

bool host_buffers_on_cpu() {
  const char* buffers = std::getenv("SQUALL_TEST_BUFFERS");
  return !buffers || std::string(buffers) != "device";
}

Runtime& runtime() {
  static Runtime* instance = [] {
    configure_kernel_cache();
    RuntimeOptions options;
    if (const char* d = std::getenv("SQUALL_TEST_DEVICE")) options.device = d;
    options.host_buffers_on_cpu = host_buffers_on_cpu();
    options.program_prefixes = programs_under_test();
    auto* r = new Runtime(options);  // never destroyed: lives until the test binary exits
    r->build_programs();
    return r;
  }();
  return *instance;
}

std::string engine_fft_backend() {
  const char* name = std::getenv("SQUALL_TEST_FFT");
  return name && *name ? name : "vkfft";
}

fft::Fft& fft(const std::string& backend) {
  // Leaked like the runtime: clFFT's own statics die at exit before ours would, so plans must not be
  // destroyed by an exit handler.
  static auto* cache = new std::map<std::string, std::unique_ptr<fft::Fft>>();
  auto& slot = (*cache)[backend];
  if (!slot) slot = std::make_unique<fft::Fft>(fft::make_backend(runtime(), backend));
  return *slot;
}

}  // namespace squall::test
