#include "client/cli_flags.h"

#include <cmath>
#include <cstdlib>
#include <iostream>

namespace squall::cli {

double number(const std::string& flag, const std::string& text, const char* unit) {
  char* end = nullptr;
  double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end || !std::isfinite(v))
    throw UsageError(flag + " " + text + ": must be a finite number (" + unit + ")");
  return v;
}

uint64_t integer(const std::string& flag, const std::string& text, uint64_t min) {
  char* end = nullptr;
  unsigned long long v = std::strtoull(text.c_str(), &end, 10);
  if (text.empty() || *end || text[0] == '-' || v < min)
    throw UsageError(flag + " " + text + ": must be an integer >= " + std::to_string(min));
  return v;
}

int run_verb(const std::string& name, const char* help, const std::vector<std::string>& args,
             const std::function<int()>& body) {
  if (args.empty() || args[0] == "help" || args[0] == "--help") {
    std::cerr << help;
    return args.empty() ? kUsage : kOk;
  }
  try {
    return body();
  } catch (const UsageError& e) {
    std::cerr << "squall " << name << ": " << e.what() << "\n";
    return kUsage;
  }
}

}  // namespace squall::cli
