// Flag parsing shared by the capability verbs of `squall` (ocean, ewave, cloud). Each parser throws
// UsageError with a message that names the flag and the value, e.g. "--wind-speed fast: must be a
// finite number (m/s)".
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "client/cli.h"

namespace squall::cli {

// A finite decimal number, nothing before or after it (no space, no hexadecimal).
double number(const std::string& flag, const std::string& text, const char* unit);
// "a,b,c" -> {"a", "b", "c"}; UsageError naming the flag for an empty item ("a,,b", "a,").
std::vector<std::string> items(const std::string& flag, const std::string& text);
// items() each a number(); UsageError naming the flag, the whole list and the item that is not one.
std::vector<double> number_list(const std::string& flag, const std::string& text);
// A decimal integer in [min, max], nothing before or after it (no sign, no space).
uint64_t integer(const std::string& flag, const std::string& text, uint64_t min = 0, uint64_t max = UINT64_MAX);
// integer() for a 32-bit field: in [min, 2^32 - 1].
uint32_t integer32(const std::string& flag, const std::string& text, uint32_t min = 0);
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

// Throws UsageError naming the first flag of `given` that `command` (e.g. "ocean tile") does not read:
// a flag given to a verb that would ignore it is refused, not dropped.
void refuse_unused(const std::string& command, const std::vector<std::string>& given,
                   const std::set<std::string>& read);

// The whole of a regular, non-empty file named by `flag`; UsageError naming the flag otherwise.
std::string read_bytes(const std::string& flag, const std::string& path);

// UsageError naming -o when `path` has an extension other than `ext` (in any case): the file is written
// as `format` whatever its name says. A name with no extension is taken as it is.
void require_extension(const std::string& path, const std::string& ext, const std::string& format);

// UsageError when --preview names the file -o names: the preview would replace the image.
void check_preview(const std::string& output, const std::string& preview);

// An EXR attribute's name for a flag as given: "squall.ewave.wake" and "--speed" give
// "squall.ewave.wake.speed".
std::string attribute_name(const std::string& prefix, const std::string& flag);

// Whether `flag` is among the (flag, value) pairs a verb recorded as given.
bool given(const std::vector<std::pair<std::string, std::string>>& flags, const std::string& flag);

// The flags of `squall` itself (--address, --timeout, ...), which go before the verb.
bool global_flag(const std::string& arg);
// What to say of one of them given after `verb`.
std::string global_flag_after(const std::string& arg, const std::string& verb);

// The folder a verb writes its frames into: made when missing, with its missing parents, and those made
// here removed again when this ends while they are empty, so that a call the server refused leaves no
// empty folder behind.
class OutputFolder {
 public:
  explicit OutputFolder(const std::string& path);
  ~OutputFolder();
  OutputFolder(const OutputFolder&) = delete;
  OutputFolder& operator=(const OutputFolder&) = delete;

 private:
  void remove_empty() const;  // those of made_ that are empty, the deepest first, up to the first that is not

  std::vector<std::filesystem::path> made_;  // the folders made here, the deepest first
};

// Runs `squall NAME SUBCOMMAND ...`: no arguments or "help" print `help`; a UsageError thrown by
// `body` is printed as "squall NAME: ..." and exits kUsage, as is a flag of squall itself given after the
// verb.
int run_verb(const std::string& name, const char* help, const std::vector<std::string>& args,
             const std::function<int()>& body);

}  // namespace squall::cli
