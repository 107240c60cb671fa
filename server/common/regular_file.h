// Reading the files an operator's flags and directories name (checkpoints, ownership records, token
// lists): only a regular file is read, opened without blocking. A FIFO left in their place would block the
// reader at open(2) until something writes to it, and a device may never end.
#pragma once

#include <optional>
#include <string>

namespace squall {

// The bytes of the regular file at `path` (symbolic links followed); nullopt when nothing is there (ENOENT,
// ENOTDIR). Throws Error(Code::DataLoss) naming the file as `name` when something else is there (a FIFO, a
// directory, a device) or the file cannot be read.
std::optional<std::string> read_regular_file(const std::string& path, const std::string& name);

}  // namespace squall
