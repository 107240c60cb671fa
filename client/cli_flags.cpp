#include "client/cli_flags.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <optional>

#include "common/error.h"
#include "common/regular_file.h"
#include "common/validate.h"

namespace squall::cli {

double number(const std::string& flag, const std::string& text, const char* unit) {
  const std::optional<double> v = validate::decimal(text);
  if (!v) throw UsageError(flag + " " + text + ": must be a finite number (" + unit + ")");
  return *v;
}

std::vector<std::string> items(const std::string& flag, const std::string& text) {
  std::vector<std::string> out;
  size_t start = 0;
  for (size_t comma = text.find(',');; comma = text.find(',', start)) {
    out.push_back(text.substr(start, comma - start));
    if (out.back().empty()) throw UsageError(flag + " " + text + ": an empty item in the list");
    if (comma == std::string::npos) return out;
    start = comma + 1;
  }
}

std::vector<double> number_list(const std::string& flag, const std::string& text) {
  std::vector<double> out;
  for (const std::string& item : items(flag, text)) {
    try {
      out.push_back(number(flag, item, ""));
    } catch (const UsageError&) {
      throw UsageError(flag + " " + text + ": " + item + " is not a finite number");
    }
  }
  return out;
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

uint32_t integer32(const std::string& flag, const std::string& text, uint32_t min) {
  return uint32_t(integer(flag, text, min, UINT32_MAX));
}

std::pair<uint32_t, uint32_t> extent(const std::string& flag, const std::string& text, uint32_t min) {
  const size_t x = text.find('x');
  const std::string usage = flag + " " + text + ": must be WxH, two integers >= " + std::to_string(min);
  if (x == std::string::npos) throw UsageError(usage);
  try {
    return {integer32(flag, text.substr(0, x), min), integer32(flag, text.substr(x + 1), min)};
  } catch (const UsageError&) {
    throw UsageError(usage);  // "8x8x8" names the whole value
  }
}

void refuse_unused(const std::string& command, const std::vector<std::string>& given,
                   const std::set<std::string>& read) {
  for (const std::string& flag : given)
    if (!read.count(flag)) throw UsageError(flag + " is not a flag of `squall " + command + "`");
}

std::string read_bytes(const std::string& flag, const std::string& path) {
  std::optional<std::string> bytes;
  try {
    bytes = read_regular_file(path, flag + " " + path);
  } catch (const Error&) {  // a FIFO, a directory, a read error: said the same way
  }
  if (!bytes) throw UsageError(flag + " " + path + ": cannot read it (a regular file that can be read is needed)");
  if (bytes->empty()) throw UsageError(flag + " " + path + ": the file is empty");
  return *bytes;
}

void require_extension(const std::string& path, const std::string& ext, const std::string& format) {
  std::string given = std::filesystem::path(path).extension().string();
  std::transform(given.begin(), given.end(), given.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  if (!given.empty() && given != ext)
    throw UsageError("-o " + path + ": the file is written as " + format + ", so its name ends in " + ext +
                     " (or has no extension)");
}

void check_preview(const std::string& output, const std::string& preview) {
  if (preview.empty()) return;
  auto resolved = [](const std::string& path) {  // through links where it can, else as written
    std::error_code error;
    const std::filesystem::path p = std::filesystem::weakly_canonical(path, error);
    return error ? std::filesystem::absolute(path).lexically_normal() : p;
  };
  if (resolved(output) == resolved(preview))
    throw UsageError("--preview " + preview + " is the file -o names: the preview would replace the image");
}

std::string attribute_name(const std::string& prefix, const std::string& flag) {
  return prefix + "." + flag.substr(std::min(flag.find_first_not_of('-'), flag.size()));
}

bool global_flag(const std::string& arg) {
  static const std::set<std::string> flags = {"--address", "--timeout",  "--request-id", "--token-file",
                                              "--tls-ca",  "--tls-cert", "--tls-key"};
  return flags.count(arg) > 0;
}

bool given(const std::vector<std::pair<std::string, std::string>>& flags, const std::string& flag) {
  return std::any_of(flags.begin(), flags.end(), [&](const auto& f) { return f.first == flag; });
}

std::string global_flag_after(const std::string& arg, const std::string& verb) {
  return arg + " is a flag of squall itself: give it before the verb (squall " + arg + " VALUE " + verb + " ...)";
}

OutputFolder::OutputFolder(const std::string& path) {
  std::error_code ignored;
  for (std::filesystem::path p = std::filesystem::absolute(path);
       p.has_relative_path() && !std::filesystem::exists(p, ignored); p = p.parent_path())
    if (const auto name = p.filename(); !name.empty() && name != "." && name != "..") made_.push_back(p);
  try {
    std::filesystem::create_directories(path);
  } catch (...) {
    remove_empty();  // the parents made before the failure
    throw;
  }
}

OutputFolder::~OutputFolder() { remove_empty(); }

void OutputFolder::remove_empty() const {
  std::error_code ignored;  // a folder that cannot be removed is left as it is
  for (const auto& p : made_)
    if (!std::filesystem::is_empty(p, ignored) || !std::filesystem::remove(p, ignored)) return;
}

int run_verb(const std::string& name, const char* help, const std::vector<std::string>& args,
             const std::function<int()>& body) {
  const bool asked =
      !args.empty() && (args[0] == "help" || std::find(args.begin(), args.end(), "--help") != args.end() ||
                        (args.size() == 2 && args[1] == "help"));
  if (args.empty() || asked) {
    std::cerr << help;
    return args.empty() ? kUsage : kOk;
  }
  try {
    for (size_t i = 0; i < args.size(); ++i)
      if (global_flag(args[i])) throw UsageError(global_flag_after(args[i], name));
    return body();
  } catch (const UsageError& e) {
    std::cerr << "squall " << name << ": " << e.what() << "\n";
    return kUsage;
  }
}

}  // namespace squall::cli
