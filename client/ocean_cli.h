// `squall ocean tile|stream|sample ...`: the Ocean service from the command line. Registered in the
// verbs table of client/cli.cpp as the verb "ocean". Flags -> request: ocean_cli_request.h; the verbs:
// ocean_cli_verbs.h; the files and CSV they write: ocean_cli_output.h.
#pragma once

#include <string>
#include <vector>

#include "client/client.h"

namespace squall::cli::ocean {

extern const char* const kVerbUsage;  // one line for `squall --help`

// Runs `squall ocean ARGS`; returns one of squall::cli's exit codes.
int run(client::Client& client, const std::vector<std::string>& args);

}  // namespace squall::cli::ocean
