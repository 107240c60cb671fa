#include "support/daemon.h"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <thread>

#include "client/client.h"
#include "support/test_runtime.h"

namespace squall::test {

std::string squalld_path() { return std::string(SQUALL_BINARY_DIR) + "/squalld"; }
std::string squall_path() { return std::string(SQUALL_BINARY_DIR) + "/squall"; }

Daemon::Daemon(const std::vector<std::string>& extra_flags, double timeout_seconds, client::ClientOptions probe)
    : dir_(temp_dir("squalld")) {
  std::vector<std::string> argv = {squalld_path(), "--listen", "127.0.0.1:0", "--port-file", dir_ + "/port"};
  argv.insert(argv.end(), extra_flags.begin(), extra_flags.end());
  if (std::find(extra_flags.begin(), extra_flags.end(), "--fft") == extra_flags.end())
    argv.insert(argv.end(), {"--fft", engine_fft_backend()});  // the in-process engines' backend: same frames
  if (!host_buffers_on_cpu()) argv.insert(argv.end(), {"--cpu-buffers", "device"});  // as the engines' runtime
  process_ = std::make_unique<Process>(argv, dir_ + "/log.txt");
  auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(long(timeout_seconds * 1000));
  auto fail_if_gone = [&](const char* waiting_for) {
    if (!process_->running() || std::chrono::steady_clock::now() > deadline)
      throw std::runtime_error(std::string("squalld never ") + waiting_for + ":\n" + process_->log());
  };
  while (!std::filesystem::exists(dir_ + "/port")) {
    fail_if_gone("listened");
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  std::ifstream(dir_ + "/port") >> port_;
  probe.address = address();
  probe.timeout_seconds = 5;
  client::Client prober(probe);
  while (!prober.wait_until_serving(1)) fail_if_gone("turned SERVING");  // stop waiting once it exits
}

}  // namespace squall::test
