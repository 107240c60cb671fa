#include "support/test_runtime.h"

#include <cstdlib>
#include <map>
#include <memory>

namespace squall::test {

Runtime& runtime() {
  static Runtime* instance = [] {
    configure_kernel_cache();
    RuntimeOptions options;
    if (const char* d = std::getenv("SQUALL_TEST_DEVICE")) options.device = d;
    auto* r = new Runtime(options);  // never destroyed: lives until the test binary exits
    r->build_programs();
    return r;
  }();
  return *instance;
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
