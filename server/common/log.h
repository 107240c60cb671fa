// Minimal thread-safe logging to stderr: one line per call, prefixed with a UTC timestamp and level.
#pragma once

#include <sstream>
#include <string>

namespace squall {

enum class LogLevel { Debug = 0, Info = 1, Warn = 2, Error = 3 };

void set_log_level(LogLevel level);
bool parse_log_level(const std::string& text, LogLevel* level);
void log_line(LogLevel level, const std::string& line);

// log(LogLevel::Info, "built ", n, " programs in ", s, " s");
template <typename... Parts>
void log(LogLevel level, const Parts&... parts) {
  std::ostringstream os;
  (os << ... << parts);
  log_line(level, os.str());
}

}  // namespace squall
