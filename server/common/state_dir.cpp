#include "common/state_dir.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cctype>
#include <cstdio>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <stdexcept>
#include <thread>

#include "common/error.h"
#include "common/log.h"
#include "common/regular_file.h"

namespace fs = std::filesystem;

namespace squall {
namespace {

constexpr const char* kSession = ".session";
constexpr const char* kOwner = ".owner";
constexpr const char* kHandover = ".handover";
constexpr const char* kLock = ".lock";
constexpr auto kStaleLock = std::chrono::seconds(10);  // a lock held this long was left by a holder that died
constexpr auto kLockWait = std::chrono::seconds(2);    // how long a change of ownership waits for the lock

// The directory's files are named within it, not by their path on this host. UNAVAILABLE: the call may
// succeed on a replica whose volume works, or here once this one does again.
[[noreturn]] void fail_io(const std::string& what, const std::string& path) {
  const std::string why = std::strerror(errno);
  fail(Code::Unavailable,
       "state directory: cannot " + what + " " + fs::path(path).filename().string() + ": " + why + "; retry later");
}

// fail_io for the file `path` this process created, which is removed first: on a full volume, a write
// that failed each checkpoint pass would otherwise leave a partial file each time.
[[noreturn]] void fail_io_removing(const std::string& what, const std::string& path) {
  const int error = errno;
  ::unlink(path.c_str());
  errno = error;
  fail_io(what, path);
}

// Writes all of `bytes` to a new file `path` (one that exists is an error) and flushes them to the device;
// the file is removed again when that fails.
void write_synced(const std::string& path, const std::string& bytes) {
  int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
  if (fd < 0) fail_io("create", path);
  size_t done = 0;
  while (done < bytes.size()) {
    ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      const int error = errno;
      ::close(fd);
      errno = error;
      fail_io_removing("write", path);
    }
    done += size_t(n);
  }
  const bool synced = ::fsync(fd) == 0;
  const int error = errno;
  if (::close(fd) != 0) fail_io_removing("sync", path);
  errno = error;
  if (!synced) fail_io_removing("sync", path);
}

// The bytes of the regular file `path`, nullopt when there is none, named within the directory in errors:
// DATA_LOSS when something else is there (a FIFO, a directory), UNAVAILABLE when it cannot be read now.
std::optional<std::string> read_whole(const std::string& path) {
  return read_regular_file(path, "state directory: " + fs::path(path).filename().string());
}

// Whether `from` is now also `to`: link(2) succeeded, or failed with EEXIST although it had made the link (a
// retransmitted NFS request whose first try was done: `from` then has two links).
bool linked(const std::string& from, const std::string& to) {
  if (::link(from.c_str(), to.c_str()) == 0) return true;
  const int error = errno;
  struct stat st;
  const bool made = error == EEXIST && ::stat(from.c_str(), &st) == 0 && st.st_nlink >= 2;
  errno = error;
  return made;
}

// The file an open descriptor names: its inode and when it was last written, by the file system's clock.
struct Stamp {
  ino_t inode = 0;
  FileTime written{};
};
std::optional<Stamp> stamp_of(int fd) {
  struct stat st;
  if (::fstat(fd, &st) != 0) return std::nullopt;
  return Stamp{st.st_ino, std::chrono::seconds(st.st_mtim.tv_sec) + std::chrono::nanoseconds(st.st_mtim.tv_nsec)};
}

// Whether two stamps are of one file: the same inode, written at the same time (a freed inode number is
// soon given to a new file; link(2) and rename(2) leave the time alone).
bool same_file(const Stamp& a, const Stamp& b) { return a.inode == b.inode && a.written == b.written; }

// Creates the empty file `path` (one that exists is an error) and returns its stamp.
Stamp new_token(const std::string& path) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
  if (fd < 0) fail_io("create", path);
  const std::optional<Stamp> s = stamp_of(fd);
  ::close(fd);
  if (!s) fail_io("stat", path);
  return *s;
}

// The stamp of the file at `path`, or nullopt when it does not exist. The file is opened first: an NFS client
// revalidates a file's attributes when it opens it (close-to-open consistency), where a bare stat may answer
// from its attribute cache, up to a minute old.
std::optional<Stamp> stamp(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);  // a FIFO would block open(2)
  if (fd < 0) return std::nullopt;
  std::optional<Stamp> s = stamp_of(fd);
  ::close(fd);
  return s;
}

// Whether nothing is at `path`, beyond doubt (stat(2) says ENOENT; any other failure is a doubt).
bool certainly_absent(const std::string& path) {
  struct stat st;
  return ::stat(path.c_str(), &st) != 0 && errno == ENOENT;
}

// Makes a rename or link in `path` durable, where the file system can: some refuse fsync on directories,
// which is harmless, and so is a directory that cannot be opened for it.
void sync_directory(const std::string& path) {
  int fd = ::open(path.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

// A name beside `file` unique to this call among all replicas, which expire() removes when left behind:
// process ids alone repeat across containers (squalld is process 1 in each), so 64 random bits drawn once
// per process come with them.
std::string temporary(const std::string& file, const char* what) {
  static const std::string process = [] {
    std::random_device random;
    char hex[17];
    std::snprintf(hex, sizeof(hex), "%08x%08x", random(), random());
    return std::to_string(::getpid()) + "-" + hex;
  }();
  static std::atomic<uint64_t> serial{0};
  return file + ".tmp-" + what + process + "-" + std::to_string(serial++);
}

// Replaces `file` (in `directory`) with `bytes` at once.
void write_atomically(const std::string& file, const std::string& directory, const std::string& bytes) {
  const std::string tmp = temporary(file, "");
  write_synced(tmp, bytes);
  if (std::rename(tmp.c_str(), file.c_str()) != 0) {
    std::remove(tmp.c_str());
    fail_io("rename into place", file);
  }
  sync_directory(directory);
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
  std::error_code error;
  const bool existed = fs::exists(path_, error);
  if (std::string why = unwritable_directory(path_); !why.empty())
    throw std::runtime_error(flag + " " + path_ + ": " + why);
  if (!existed) fs::permissions(path_, fs::perms::owner_all, fs::perm_options::replace, error);
  struct stat st;
  if (::stat(path_.c_str(), &st) != 0) throw std::runtime_error(flag + " " + path_ + ": " + std::strerror(errno));
  identity_ = {st.st_dev, st.st_ino};
  // Ownership is claimed by link(2) (claim_owner): a file system without hard links cannot hold it.
  const std::string probe = temporary(path_ + "/.squalld-link-test", ""), second_name = probe + "-link";
  try {
    new_token(probe);
  } catch (const Error& e) {
    throw std::runtime_error(flag + " " + path_ + ": " + e.what());
  }
  const bool links = ::link(probe.c_str(), second_name.c_str()) == 0;
  const std::string why = std::strerror(errno);
  std::remove(second_name.c_str());
  std::remove(probe.c_str());
  if (!links)
    throw std::runtime_error(flag + " " + path_ + ": cannot make a hard link in the directory (" + why +
                             "): session ownership is claimed by link(2)");
}

std::optional<std::string> StateDir::file_of(const std::string& id, const char* suffix) const {
  if (id.empty() || id.size() > 128) return std::nullopt;
  for (char c : id)
    if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-')) return std::nullopt;
  return path_ + "/" + id + suffix;
}

// Replica names are free text ("host:port"): every byte outside [A-Za-z0-9.-] is written as _XX (hex).
std::string StateDir::replica_file(const std::string& replica) const {
  std::string name;
  for (unsigned char c : replica) {
    char hex[4];
    std::snprintf(hex, sizeof(hex), "_%02x", c);
    name += std::isalnum(c) || c == '.' || c == '-' ? std::string(1, char(c)) : std::string(hex);
  }
  return path_ + "/replicas/" + name;
}

bool StateDir::same_directory() const {
  struct stat st;
  return ::stat(path_.c_str(), &st) == 0 && S_ISDIR(st.st_mode) && st.st_dev == identity_.first &&
         st.st_ino == identity_.second;
}

void StateDir::require_same_directory() const {
  if (!same_directory())
    fail(Code::Unavailable,
         "state directory: it is no longer the directory squalld started with (unmounted, moved or replaced); "
         "retry later");
}

void StateDir::write(const std::string& id, const std::string& bytes) const {
  auto file = file_of(id, kSession);
  if (!file) fail(Code::Internal, "state directory: id \"" + id + "\" cannot name a file");
  require_same_directory();
  write_atomically(*file, path_, bytes);
}

bool StateDir::write_owned(const std::string& id, const std::string& bytes, const std::string& replica) const {
  return put_under_owner_lock(id, kSession, bytes, [&](const std::string& temporary, const std::string& file) {
    const std::optional<std::string> now = owner(id);
    if (!(now ? *now == replica : !owner_missing(id))) return false;
    if (std::rename(temporary.c_str(), file.c_str()) != 0) fail_io("rename into place", file);
    return true;
  });
}

std::optional<std::string> StateDir::read(const std::string& id) const {
  auto file = file_of(id, kSession);
  return file ? read_whole(*file) : std::nullopt;
}

bool StateDir::checkpointed(const std::string& id) const {
  auto file = file_of(id, kSession);
  std::error_code error;
  return file && fs::exists(*file, error);
}

void StateDir::remove(const std::string& id, const std::string& owner) const {
  for (const char* suffix : {kSession, kHandover})
    if (auto file = file_of(id, suffix)) std::remove(file->c_str());
  give_up(id, owner);
}

void StateDir::give_up(const std::string& id, const std::string& owner) const {
  try {
    remove_owner_if(id, owner);
  } catch (const std::exception& e) {
    log(LogLevel::Error, "state directory: giving up the ownership of ", id, ": ", e.what());
  }
}

bool StateDir::create_owner(const std::string& id, const std::string& replica) const {
  return claim_owner(id, replica, [](const std::string&) { return false; });
}

bool StateDir::claim_owner(const std::string& id, const std::string& replica,
                           const std::function<bool(const std::string& owner)>& may_take, std::string* holder) const {
  return put_under_owner_lock(id, kOwner, replica, [&](const std::string& mine, const std::string& file) {
    const std::optional<std::string> owner = read_whole(file);
    if (owner == replica) return true;
    if (owner && !may_take(*owner)) {
      if (holder) *holder = *owner;
      return false;
    }
    if (owner && std::remove(file.c_str()) != 0) fail_io("remove the former owner", file);
    if (!linked(mine, file)) fail_io("link into place", file);
    return true;
  });
}

bool StateDir::put_under_owner_lock(const std::string& id, const char* suffix, const std::string& bytes,
                                    const Put& put) const {
  auto file = file_of(id, suffix);
  if (!file) fail(Code::Internal, "state directory: id \"" + id + "\" cannot name a file");
  require_same_directory();
  const std::string temporary_file = temporary(*file, "");
  write_synced(temporary_file, bytes);  // before the lock, which is then held for a read and a link or rename
  bool put_in_place = false;
  try {
    with_owner_lock(id, [&] { put_in_place = put(temporary_file, *file); });
  } catch (...) {
    std::remove(temporary_file.c_str());
    throw;
  }
  std::remove(temporary_file.c_str());  // linked: its other name; renamed: gone already
  if (put_in_place) sync_directory(path_);
  return put_in_place;
}

bool StateDir::remove_owner_if(const std::string& id, const std::string& replica) const {
  auto file = file_of(id, kOwner);
  if (!file || read_whole(*file) != replica) return false;  // most files another's: no lock for them
  bool removed = false;
  with_owner_lock(id, [&] {
    if (read_whole(*file) != replica) return;
    if (std::remove(file->c_str()) != 0) fail_io("remove", *file);
    removed = true;
  });
  sync_directory(path_);
  return removed;
}

// The lock is a file <id>.lock made by link(2) of a temporary, so that one replica at a time holds it, and
// told from a later lock by its inode and time (same_file). It is held for a few file operations. One older
// than kStaleLock was left by a holder that died (or stalled that long) holding it, and is broken.
void StateDir::with_owner_lock(const std::string& id, const std::function<void()>& f) const {
  const std::string lock = *file_of(id, kLock);
  const std::string token = temporary(lock, "");
  const Stamp mine = new_token(token);
  const auto deadline = std::chrono::steady_clock::now() + kLockWait;
  auto pause = std::chrono::milliseconds(1);
  while (!linked(token, lock)) {
    const int error = errno;
    if (error == EEXIST) break_if_stale(lock);
    if (error != EEXIST || std::chrono::steady_clock::now() > deadline) {
      std::remove(token.c_str());
      errno = error;
      if (error != EEXIST) fail_io("lock", lock);
      fail(Code::Unavailable, "the ownership of " + id + " is being changed by another replica; retry in a moment");
    }
    std::this_thread::sleep_for(pause);
    pause = std::min(2 * pause, std::chrono::milliseconds(32));
  }
  std::remove(token.c_str());  // the lock is the same file, by its other name
  const auto unlock = [&] {    // not a lock broken as stale and taken since
    if (const std::optional<Stamp> now = stamp(lock); now && same_file(*now, mine)) std::remove(lock.c_str());
  };
  try {
    f();
  } catch (...) {
    unlock();
    throw;
  }
  unlock();
}

void StateDir::break_if_stale(const std::string& lock) const {
  const std::optional<Stamp> stale = stamp(lock);
  if (!stale || file_system_now() - stale->written <= kStaleLock) return;
  const std::string aside = temporary(lock, "stale-");
  if (std::rename(lock.c_str(), aside.c_str()) != 0) return;  // broken by another
  const std::optional<Stamp> moved = stamp(aside);
  if (!moved || !same_file(*moved, *stale)) (void)::link(aside.c_str(), lock.c_str());  // a fresh one: put back
  std::remove(aside.c_str());
}

std::optional<std::string> StateDir::owner(const std::string& id) const {
  auto file = file_of(id, kOwner);
  try {
    return file ? read_whole(*file) : std::nullopt;
  } catch (const Error& e) {  // no owner record, or none readable now: no owner named, but not missing either
    log(LogLevel::Error, e.what());
    return std::nullopt;
  }
}

bool StateDir::owner_missing(const std::string& id) const {
  auto file = file_of(id, kOwner);
  return file && certainly_absent(*file) && same_directory();  // not in a directory gone or replaced
}

void StateDir::clear_ownership_of(const std::string& replica) const {
  std::error_code error;
  const std::string suffix = kOwner;
  for (const auto& entry : fs::directory_iterator(path_, error)) {
    const std::string name = entry.path().filename().string();
    if (name.size() <= suffix.size() || !name.ends_with(suffix)) continue;
    give_up(name.substr(0, name.size() - suffix.size()), replica);
  }
}

void StateDir::heartbeat(const std::string& replica) const {
  const std::string file = replica_file(replica);
  ::mkdir((path_ + "/replicas").c_str(), 0700);  // not the state directory: one removed stays so
  // Rewritten in place, not truncated: a beat whose write fails leaves the file's time as it was, and this
  // replica looks older to the others, as it should.
  const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_CLOEXEC | O_NONBLOCK, 0600);
  const std::string line = replica + "\n";  // rewriting it moves its time forward
  ssize_t written = fd >= 0 ? ::write(fd, line.data(), line.size()) : -1;
  int error = errno;
  if (fd >= 0 && ::close(fd) != 0 && written == ssize_t(line.size()))  // a network file system may say so only now
    written = -1, error = errno;
  if (written != ssize_t(line.size()))
    fail(Code::Unavailable, "state directory: cannot write this replica's heartbeat " + file + ": " +
                                (written >= 0 ? std::string("a short write") : std::strerror(error)));
  std::lock_guard<std::mutex> lock(beat_mutex_);
  beat_ = {file, std::chrono::steady_clock::now()};
}

void StateDir::retire(const std::string& replica) const { std::remove(replica_file(replica).c_str()); }

bool StateDir::alive(const std::string& replica, std::chrono::milliseconds timeout) const {
  const std::optional<Stamp> beat = stamp(replica_file(replica));
  return beat && file_system_now() - beat->written <= timeout;
}

// The time stamped on this process's last heartbeat plus the time since by this machine's steady clock (read
// while the next beat is written, up to one beat late); before the first, or once it is retired, the time
// stamped on a probe file (this machine's clock if none can be written).
FileTime StateDir::file_system_now() const {
  std::pair<std::string, std::chrono::steady_clock::time_point> beat;
  {
    std::lock_guard<std::mutex> lock(beat_mutex_);
    beat = beat_;
  }
  if (!beat.first.empty())
    if (const std::optional<Stamp> own = stamp(beat.first))
      return own->written + (std::chrono::steady_clock::now() - beat.second);
  const std::string probe = temporary(path_ + "/.squalld-clock", "");
  try {
    const Stamp created = new_token(probe);
    std::remove(probe.c_str());
    return created.written;
  } catch (const Error&) {
    return std::chrono::system_clock::now().time_since_epoch();
  }
}

void StateDir::request_handover(const std::string& id) const {
  auto file = file_of(id, kHandover);
  if (!file) return;
  const int fd = ::open(file->c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC | O_NONBLOCK, 0600);
  if (fd < 0) return;  // asked again at the client's retry
  const std::string line = id + "\n";
  if (::write(fd, line.data(), line.size()) != ssize_t(line.size()))
    log(LogLevel::Warn, "state directory: the handover request of ", id, " was not written whole");
  ::close(fd);
}

std::vector<std::string> StateDir::handover_requests() const {
  std::vector<std::string> ids;
  std::error_code error;
  const std::string suffix = kHandover;
  for (const auto& entry : fs::directory_iterator(path_, error)) {
    const std::string name = entry.path().filename().string();
    if (name.size() > suffix.size() && name.ends_with(suffix))
      ids.push_back(name.substr(0, name.size() - suffix.size()));
  }
  return ids;
}

void StateDir::clear_handover(const std::string& id) const {
  if (auto file = file_of(id, kHandover)) std::remove(file->c_str());
}

bool StateDir::expired(const std::string& id, std::chrono::milliseconds ttl, const std::string& self,
                       const HeldHere& held_here) const {
  const std::optional<std::string> file = file_of(id, kSession);
  const std::optional<Stamp> written = file ? stamp(*file) : std::nullopt;
  const FileTime now = file_system_now();
  return written && now - written->written > ttl && !held_live(id, ttl, now, self, held_here);
}

size_t StateDir::expire(std::chrono::milliseconds ttl, const std::string& self, const HeldHere& held_here) const {
  size_t removed = 0;
  std::error_code error;
  const auto now = file_system_now();  // the clock the files are stamped by
  for (const auto& entry : fs::directory_iterator(path_, error)) {
    const std::string name = entry.path().filename().string();
    const bool expiring = name.ends_with(kSession) || name.ends_with(kHandover) || name.ends_with(kLock) ||
                          name.find(".tmp-") != std::string::npos;
    if (!expiring && name.ends_with(kOwner))
      removed += expire_owner(name.substr(0, name.size() - std::strlen(kOwner)), ttl, now);
    if (!expiring) continue;
    const std::optional<Stamp> written = stamp(entry.path().string());
    if (!written || now - written->written <= ttl) continue;
    if (name.ends_with(kSession) &&
        held_live(name.substr(0, name.size() - std::strlen(kSession)), ttl, now, self, held_here))
      continue;
    removed += fs::remove(entry.path(), error) ? 1 : 0;
  }
  return removed + expire_heartbeats(ttl, now);
}

// An owner file is left behind when its replica was killed holding the session, and nothing gives it up
// once the session's checkpoint has expired too: removed under the session's lock when it names a replica
// that has not beaten for `ttl` (or names none) and no checkpoint has come back since.
bool StateDir::expire_owner(const std::string& id, std::chrono::milliseconds ttl, FileTime now) const {
  const std::optional<std::string> file = file_of(id, kOwner), checkpoint = file_of(id, kSession);
  if (!file || !certainly_absent(*checkpoint)) return false;
  const std::optional<Stamp> written = stamp(*file);
  if (!written || now - written->written <= ttl) return false;
  bool removed = false;
  try {
    with_owner_lock(id, [&] {
      std::optional<std::string> named;
      try {
        named = read_whole(*file);
      } catch (const Error& e) {
        if (e.code() != Code::DataLoss) return;  // unreadable for now: kept; DataLoss: no owner record at all
      }
      if (!certainly_absent(*checkpoint) || (named && !silent_for(*named, ttl, now))) return;
      removed = std::remove(file->c_str()) == 0;
    });
  } catch (const Error&) {  // the lock is another replica's now, or the directory failed: the next pass
  }
  return removed;
}

// Whether session `id` is held live: its owner file names another replica that has beaten within `ttl` of
// `now`, or `self` where `held_here` says it holds the session (an owner file of its own that it does not hold
// is one left behind), or cannot be read now. The owner evicts such a session when it is idle, while its
// checkpoint may be as old as its last periodic write, or as its resumption where it checkpoints only when
// it drains.
bool StateDir::held_live(const std::string& id, std::chrono::milliseconds ttl, FileTime now, const std::string& self,
                         const HeldHere& held_here) const {
  const std::optional<std::string> file = file_of(id, kOwner);
  if (!file) return false;
  try {
    const std::optional<std::string> named = read_whole(*file);
    if (named && !self.empty() && *named == self) return held_here && held_here(id);
    return named && !silent_for(*named, ttl, now);
  } catch (const Error& e) {
    return e.code() != Code::DataLoss;  // unreadable for now: kept; DataLoss: no owner record at all
  }
}

// Beyond doubt: the heartbeat file is gone, or it was last written more than `ttl` before `now`.
bool StateDir::silent_for(const std::string& replica, std::chrono::milliseconds ttl, FileTime now) const {
  const std::string beat_file = replica_file(replica);
  const std::optional<Stamp> beat = stamp(beat_file);
  return beat ? now - beat->written > ttl : certainly_absent(beat_file);
}

size_t StateDir::expire_heartbeats(std::chrono::milliseconds ttl, FileTime now) const {
  size_t removed = 0;
  std::error_code error;
  for (const auto& entry : fs::directory_iterator(path_ + "/replicas", error)) {
    const std::optional<Stamp> beat = stamp(entry.path().string());
    if (beat && now - beat->written > ttl) removed += fs::remove(entry.path(), error) ? 1 : 0;
  }
  return removed;
}

}  // namespace squall
