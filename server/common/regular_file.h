// Reading the files an operator's flags and directories name (checkpoints, ownership records, token
// lists): only a regular file is read, opened without blocking. A FIFO left in their place would block the
// reader at open(2) until something writes to it, and a device may never end.
#pragma once

#include <optional>
#include <string>

namespace squall {

// The bytes of the regular file at `path` (symbolic links followed); nullopt when nothing is there (ENOENT,
// ENOTDIR). Throws, naming the file as `name`, Error(Code::DataLoss) when something else is there (a FIFO,
// a directory, a device), and Error(Code::Unavailable) when the file cannot be opened or read (EIO, ESTALE,
// EACCES, ...: perhaps for a moment).
std::optional<std::string> read_regular_file(const std::string& path, const std::string& name);

}  // namespace squall
