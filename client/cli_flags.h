// Flag parsing shared by the capability verbs of `squall` (ocean, ewave, cloud). Each parser throws
// UsageError with a message that names the flag and the value, e.g. "--wind-speed fast: must be a
// finite number (m/s)".
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "client/cli.h"

namespace squall::cli {

double number(const std::string& flag, const std::string& text, const char* unit);
// A decimal integer in [min, max], nothing before or after it (no sign, no space).
uint64_t integer(const std::string& flag, const std::string& text, uint64_t min = 0, uint64_t max = UINT64_MAX);
// "WxH": two integers in [min, 2^32 - 1] and nothing else.
std::pair<uint32_t, uint32_t> extent(const std::string& flag, const std::string& text, uint32_t min);

template <typename Enum>
Enum named(const std::string& flag, const std::string& text, const std::map<std::string, Enum>& names) {
  auto it = names.find(text);
  if (it != names.end()) return it->second;
  std::string known;
  for (const auto& [name, value] : names) known += (known.empty() ? "" : " | ") + name;
  throw UsageError(flag + " " + text + ": must be one of " + known);
}

// Runs `squall NAME SUBCOMMAND ...`: no arguments or "help" print `help`; a UsageError thrown by
// `body` is printed as "squall NAME: ..." and exits kUsage.
int run_verb(const std::string& name, const char* help, const std::vector<std::string>& args,
             const std::function<int()>& body);

}  // namespace squall::cli
