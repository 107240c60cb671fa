// A file written whole or not at all: the bytes go to a temporary file beside `path` (same folder, so the
// same file system), and commit() renames it over `path` with the mode of the file it replaces. A write that
// fails (a full disk, a quota) leaves the file that was at `path` as it was, and the temporary file is
// removed. Only a regular file this user may write (or none) is replaced so: a device, a pipe or a symbolic
// link at `path` (/dev/stdout, a link into another folder) is written in place, as the user named it, as is
// a file in a folder where no other file can be made.
#pragma once

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <optional>
#include <string>
#include <utility>

namespace squall::client {

class ReplacingFile {
 public:
  explicit ReplacingFile(std::string path) : path_(std::move(path)), temp_(path_) {
    struct stat st {};
    const bool absent = ::lstat(path_.c_str(), &st) != 0 && errno == ENOENT;
    // In place, and refused there as before: what is no regular file, and a file this user may not write.
    if (!absent && (!S_ISREG(st.st_mode) || ::access(path_.c_str(), W_OK) != 0)) return;
    static std::atomic<unsigned> serial{0};
    const std::string temp = path_ + ".partial-" + std::to_string(::getpid()) + "-" + std::to_string(serial++);
    const int fd = ::open(temp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);  // less the umask
    if (fd < 0) return;  // no file can be made beside it: written in place
    ::close(fd);
    temp_ = temp;
    if (!absent) mode_ = st.st_mode & 07777;
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
    if (temp_ != path_ && mode_ && ::chmod(temp_.c_str(), *mode_) != 0) return false;
    committed_ = temp_ == path_ || std::rename(temp_.c_str(), path_.c_str()) == 0;
    return committed_;
  }

 private:
  std::string path_, temp_;
  std::optional<mode_t> mode_;  // the replaced file's
  bool committed_ = false;
};

}  // namespace squall::client
