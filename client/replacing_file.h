// A file written whole or not at all: the bytes go to a temporary file beside `path` (same folder, so the
// same file system), and commit() renames it over `path`. A write that fails (a full disk, a quota) leaves
// the file that was at `path` as it was, and the temporary file is removed. Only a regular file (or none)
// is replaced so: a device, a pipe or a symbolic link at `path` (/dev/stdout, a link into another folder)
// is written in place, as the user named it.
#pragma once

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <string>
#include <utility>

namespace squall::client {

class ReplacingFile {
 public:
  explicit ReplacingFile(std::string path) : path_(std::move(path)) {
    struct stat st {};
    const bool absent = ::lstat(path_.c_str(), &st) != 0 && errno == ENOENT;
    temp_ = absent || S_ISREG(st.st_mode) ? path_ + ".partial-" + std::to_string(::getpid()) : path_;
  }
  ~ReplacingFile() {
    if (!committed_ && temp_ != path_) std::remove(temp_.c_str());
  }
  ReplacingFile(const ReplacingFile&) = delete;
  ReplacingFile& operator=(const ReplacingFile&) = delete;

  // Where to write the bytes, closed before commit().
  const std::string& temp() const { return temp_; }

  // Puts the written file at `path`, replacing what was there; false (errno says why) when it cannot.
  bool commit() {
    committed_ = temp_ == path_ || std::rename(temp_.c_str(), path_.c_str()) == 0;
    return committed_;
  }

 private:
  std::string path_, temp_;
  bool committed_ = false;
};

}  // namespace squall::client
