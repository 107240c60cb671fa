// The `squall texture` commands beside `advect`: `river` (BakeVelocity) and `deform` (DeformTexture).
// Each takes the verb's arguments (args[0] is the command) and returns one of squall::cli's exit codes.
#pragma once

#include <string>
#include <vector>

#include "client/client.h"

namespace squall::cli::texture {

extern const char* const kRiverHelp;
extern const char* const kDeformHelp;

int river(client::Client& client, const std::vector<std::string>& args);
int deform(client::Client& client, const std::vector<std::string>& args);

}  // namespace squall::cli::texture
