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
    Request r = parse(args);
    if (args[0] == "tile") return tile(client, r);
    if (args[0] == "stream") return stream(client, r);
    if (args[0] == "sample") return sample(client, r);
    throw UsageError("unknown ocean verb " + args[0] + " (tile, stream or sample)");
  });
}

}  // namespace squall::cli::ocean
