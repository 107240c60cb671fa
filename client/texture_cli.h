// `squall texture advect ...`: the Textures service from the command line. Registered in the verbs table
// of client/cli.cpp as the verb "texture".
#pragma once

#include <string>
#include <vector>

#include "client/client.h"

namespace squall::cli::texture {

extern const char* const kVerbUsage;  // one line for `squall --help`

// Runs `squall texture ARGS`; returns one of squall::cli's exit codes.
int run(client::Client& client, const std::vector<std::string>& args);

}  // namespace squall::cli::texture
