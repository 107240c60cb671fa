// StateDir: a directory shared by the replicas of a deployment (squalld --state-dir), holding one file per
// checkpointed session, named by the session's id: "<id>.session", the bytes of encode_checkpoint().
// Writes are atomic (a temporary file, fsync, rename, fsync of the directory), so a reader on another
// replica sees the previous checkpoint or the new one, never half of one. Files not rewritten for longer
// than the session TTL are expired. Ids name files only when they are made of [a-z0-9-] (every id squalld
// makes or accepts is), so no id reaches outside the directory.
#pragma once

#include <chrono>
#include <optional>
#include <string>

namespace squall {

// Creates `path` if needed and checks that a file can be written in it: "" when it can, else why not.
std::string unwritable_directory(const std::string& path);

class StateDir {
 public:
  // Creates `path` if needed; std::runtime_error naming `flag` when it cannot be created or written.
  StateDir(std::string path, const std::string& flag);

  void write(const std::string& id, const std::string& bytes) const;
  std::optional<std::string> read(const std::string& id) const;  // nullopt: no such file (or no such id)
  void remove(const std::string& id) const;
  // Removes the session files last written more than `ttl` ago; returns how many.
  size_t expire(std::chrono::milliseconds ttl) const;

  const std::string& path() const { return path_; }

 private:
  std::optional<std::string> file_of(const std::string& id) const;
  std::string path_;
};

}  // namespace squall
