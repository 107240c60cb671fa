// The `squall` command line: global flags, then a verb. Verbs register in a table so later capabilities
// add theirs (e.g. `squall ocean tile`) without touching the dispatcher.
#pragma once

#include <functional>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "client/client.h"

namespace squall::cli {

// Exit codes of `squall`.
enum ExitCode {
  kOk = 0,
  kNotServing = 1,   // `health`: the server answered, but is not SERVING
  kUsage = 2,        // bad command line
  kUnreachable = 3,  // no answer: UNAVAILABLE or DEADLINE_EXCEEDED
  kRefused = 4,      // the server answered with another error (INVALID_ARGUMENT, NOT_FOUND, ...)
  kLocalError = 5,   // the request succeeded but a local step failed (writing a file, ...)
};

// A verb's bad command line: the dispatcher prints it and exits kUsage.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct Verb {
  std::string usage;  // one line: "info  print the daemon's version, devices, kernels and limits"
  std::function<int(client::Client&, const std::vector<std::string>& args)> run;
};

std::map<std::string, Verb>& verbs();  // name -> verb; the core verbs are always present

int main(int argc, char** argv);

}  // namespace squall::cli
