#include "common/state_dir.h"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>

#include "common/error.h"

namespace fs = std::filesystem;

namespace squall {
namespace {

constexpr const char* kSuffix = ".session";

void fail_io(const std::string& what, const std::string& path) {
  fail(Code::Internal, "state directory: cannot " + what + " " + path + ": " + std::strerror(errno));
}

// Writes all of `bytes` to `path` and flushes them to the device.
void write_synced(const std::string& path, const std::string& bytes) {
  int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (fd < 0) fail_io("create", path);
  size_t done = 0;
  while (done < bytes.size()) {
    ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      ::close(fd);
      fail_io("write", path);
    }
    done += size_t(n);
  }
  if (::fsync(fd) != 0 || ::close(fd) != 0) fail_io("sync", path);
}

void sync_directory(const std::string& path) {
  int fd = ::open(path.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) fail_io("open", path);
  ::fsync(fd);  // makes the rename durable; some file systems refuse fsync on directories, which is harmless
  ::close(fd);
}

}  // namespace

std::string unwritable_directory(const std::string& path) {
  std::error_code error;
  fs::create_directories(path, error);
  if (error) return "cannot create the directory: " + error.message();
  const std::string probe = path + "/.squalld-write-test-" + std::to_string(::getpid());
  if (!std::ofstream(probe).good()) return std::string("cannot write to the directory: ") + std::strerror(errno);
  fs::remove(probe, error);
  return "";
}

StateDir::StateDir(std::string path, const std::string& flag) : path_(std::move(path)) {
  if (std::string why = unwritable_directory(path_); !why.empty()) throw std::runtime_error(flag + " " + path_ + ": " + why);
}

std::optional<std::string> StateDir::file_of(const std::string& id) const {
  if (id.empty() || id.size() > 128) return std::nullopt;
  for (char c : id)
    if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-')) return std::nullopt;
  return path_ + "/" + id + kSuffix;
}

void StateDir::write(const std::string& id, const std::string& bytes) const {
  auto file = file_of(id);
  if (!file) fail(Code::Internal, "state directory: id \"" + id + "\" cannot name a file");
  static std::atomic<uint64_t> serial{0};  // temporaries unique per process and per write
  const std::string tmp = *file + ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(serial++);
  write_synced(tmp, bytes);
  if (std::rename(tmp.c_str(), file->c_str()) != 0) {
    std::remove(tmp.c_str());
    fail_io("rename into place", *file);
  }
  sync_directory(path_);
}

std::optional<std::string> StateDir::read(const std::string& id) const {
  auto file = file_of(id);
  if (!file) return std::nullopt;
  std::ifstream in(*file, std::ios::binary);
  if (!in) return std::nullopt;
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void StateDir::remove(const std::string& id) const {
  if (auto file = file_of(id)) std::remove(file->c_str());
}

size_t StateDir::expire(std::chrono::milliseconds ttl) const {
  size_t removed = 0;
  std::error_code error;
  const auto now = fs::file_time_type::clock::now();
  for (const auto& entry : fs::directory_iterator(path_, error)) {
    const std::string name = entry.path().filename().string();
    const bool session = name.size() > std::strlen(kSuffix) && name.ends_with(kSuffix);
    const bool stale_tmp = name.find(std::string(kSuffix) + ".tmp-") != std::string::npos;
    if (!session && !stale_tmp) continue;
    auto written = entry.last_write_time(error);
    if (error || now - written <= ttl) continue;
    removed += fs::remove(entry.path(), error) ? 1 : 0;
  }
  return removed;
}

}  // namespace squall
