#include "client/cli_flags.h"

#include <cctype>
#include <cerrno>
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

uint64_t integer(const std::string& flag, const std::string& text, uint64_t min, uint64_t max) {
  char* end = nullptr;
  errno = 0;
  unsigned long long v = std::strtoull(text.c_str(), &end, 10);
  if (text.empty() || *end || !std::isdigit(static_cast<unsigned char>(text[0])) || errno == ERANGE || v < min ||
      v > max)
    throw UsageError(flag + " " + text + ": must be an integer " +
                     (max == UINT64_MAX ? ">= " + std::to_string(min)
                                        : "in [" + std::to_string(min) + ", " + std::to_string(max) + "]"));
  return v;
}

std::pair<uint32_t, uint32_t> extent(const std::string& flag, const std::string& text, uint32_t min) {
  const size_t x = text.find('x');
  const std::string usage = flag + " " + text + ": must be WxH, two integers >= " + std::to_string(min);
  if (x == std::string::npos) throw UsageError(usage);
  try {
    return {uint32_t(integer(flag, text.substr(0, x), min, UINT32_MAX)),
            uint32_t(integer(flag, text.substr(x + 1), min, UINT32_MAX))};
  } catch (const UsageError&) {
    throw UsageError(usage);  // "8x8x8" names the whole value
  }
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
