// Child processes for integration tests: squalld and the squall CLI, run for real.
#pragma once

#include <sys/types.h>

#include <string>
#include <vector>

namespace squall::test {

class Process {
 public:
  // Starts argv[0] with stdout and stderr appended to log_path.
  Process(const std::vector<std::string>& argv, const std::string& log_path);
  ~Process();  // kills the child if it still runs
  Process(const Process&) = delete;
  Process& operator=(const Process&) = delete;

  pid_t pid() const { return pid_; }
  // The CPU time the child has used so far (user + system, all its threads), s, from /proc/PID/stat.
  double cpu_seconds() const;
  void signal(int sig) const;
  // Waits up to `seconds`; returns the exit code, or -1 on timeout, or -(128 + signal) if killed.
  int wait(double seconds);
  bool running();
  std::string log() const;

 private:
  pid_t pid_ = -1;
  bool reaped_ = false;
  int status_ = 0;
  std::string log_path_;
};

// Runs a command to completion and returns its exit code; its output goes to *output.
int run(const std::vector<std::string>& argv, std::string* output, double timeout_seconds = 60);

std::string temp_dir(const std::string& name);  // a fresh directory under the build tree
std::string read_file(const std::string& path);

}  // namespace squall::test
