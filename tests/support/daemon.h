// A real squalld for integration tests: started on 127.0.0.1 with a free port, SERVING when the
// constructor returns, killed when the object is destroyed (hold shared ones in function-local statics,
// not leaked pointers, so that the process ends with the test binary).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "client/client.h"
#include "support/process.h"

namespace squall::test {

std::string squalld_path();  // the squalld of this build tree
std::string squall_path();   // the squall CLI of this build tree

class Daemon {
 public:
  // Starts squalld with `--listen 127.0.0.1:0 --port-file ...` and the extra flags. Throws, with the
  // daemon's log, when it exits or is not SERVING within `timeout_seconds`. `probe`: how to connect
  // while waiting (its TLS files, for a daemon started with --tls-*); the address is filled in.
  explicit Daemon(const std::vector<std::string>& extra_flags = {}, double timeout_seconds = 600,
                  client::ClientOptions probe = {});

  std::string address() const { return "127.0.0.1:" + std::to_string(port_); }
  Process& process() { return *process_; }
  bool running() { return process_->running(); }

 private:
  std::string dir_;
  int port_ = 0;
  std::unique_ptr<Process> process_;
};

}  // namespace squall::test
