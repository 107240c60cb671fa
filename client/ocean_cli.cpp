#include "client/ocean_cli.h"

#include "client/cli_flags.h"
#include "client/ocean_cli_request.h"
#include "client/ocean_cli_verbs.h"

namespace squall::cli::ocean {

const char* const kVerbUsage =
    "ocean tile|stream|sample ...  ocean surface tiles (EXR + PNG), frame sequences, CSV point samples; "
    "`squall ocean help` lists the flags";

int run(client::Client& client, const std::vector<std::string>& args) {
  return run_verb("ocean", kHelp, args, [&] {
    const auto read = kVerbFlags.find(args[0]);
    if (read == kVerbFlags.end()) throw UsageError("unknown ocean verb " + args[0] + " (tile, stream or sample)");
    Request r = parse(args);
    refuse_unused("ocean " + args[0], r.run_flags, read->second);
    if (args[0] == "tile") return tile(client, r);
    if (args[0] == "stream") return stream(client, r);
    return sample(client, r);
  });
}

}  // namespace squall::cli::ocean
