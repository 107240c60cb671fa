// `squall cloud build|render ...`: the Clouds service from the command line. Registered in the verbs table
// of client/cli.cpp as the verb "cloud".
#pragma once

#include <string>
#include <vector>

#include "client/client.h"

namespace squall::cli::cloud {

extern const char* const kVerbUsage;  // one line for `squall --help`

// Runs `squall cloud ARGS`; returns one of squall::cli's exit codes.
int run(client::Client& client, const std::vector<std::string>& args);

}  // namespace squall::cli::cloud
