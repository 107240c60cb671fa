#include "runtime/kernel_sources.h"

#include <set>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "common/error.h"

namespace squall {
namespace fs = std::filesystem;

KernelSources::KernelSources(const std::string& dir) {
  for (const auto& f : embedded_system_kernel_headers()) files_[f.path] = f.text;
  if (dir.empty()) {
    for (const auto& f : embedded_kernel_files()) files_[f.path] = f.text;
    return;
  }
  if (!fs::is_directory(dir)) fail(Code::InvalidArgument, "--kernel-dir " + dir + " is not a directory");
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    auto ext = entry.path().extension();
    if (!entry.is_regular_file() || (ext != ".cl" && ext != ".clh" && ext != ".h")) continue;
    std::ifstream in(entry.path());
    std::stringstream text;
    text << in.rdbuf();
    files_[fs::relative(entry.path(), dir).generic_string()] = text.str();
  }
}

std::vector<std::string> KernelSources::programs() const {
  std::vector<std::string> out;
  for (const auto& [path, text] : files_)
    if (path.size() > 3 && path.compare(path.size() - 3, 3, ".cl") == 0) out.push_back(path);
  return out;
}

std::string KernelSources::expanded(const std::string& program) const {
  std::string out;
  std::set<std::string> included;
  splice(program, "", out, included);
  return out;
}

void KernelSources::splice(const std::string& path, const std::string& from, std::string& out,
                           std::set<std::string>& included) const {
  auto it = files_.find(path);
  if (it == files_.end())
    fail(Code::Internal,
         "kernel source " + path + " not found" + (from.empty() ? "" : " (included from " + from + ")"));
  if (!included.insert(path).second) return;  // every file is spliced once, like #pragma once
  std::istringstream lines(it->second);
  std::string line;
  int number = 0;
  out += "#line 1 \"" + path + "\"\n";
  while (std::getline(lines, line)) {
    ++number;
    auto first = line.find_first_not_of(" \t");
    bool is_include = first != std::string::npos && line.compare(first, 10, "#include \"") == 0;
    if (!is_include) {
      out += line + "\n";
      continue;
    }
    auto open = line.find('"');
    auto close = line.find('"', open + 1);
    splice(line.substr(open + 1, close - open - 1), path, out, included);
    out += "#line " + std::to_string(number + 1) + " \"" + path + "\"\n";
  }
}

std::string KernelSources::build_options(const std::string& program) const {
  const std::string marker = "// squall-build-options:";
  const std::string& text = files_.at(program);
  if (text.compare(0, marker.size(), marker) != 0) return "";
  return text.substr(marker.size(), text.find('\n') - marker.size());
}

}  // namespace squall
