// The verbs of `squall ocean`: each sends its request to the Ocean service and writes what comes back
// (ocean_cli_output.h). Each returns one of squall::cli's exit codes; a missing flag throws UsageError,
// a refused call client::RpcError.
#pragma once

#include "client/client.h"
#include "client/ocean_cli_request.h"

namespace squall::cli::ocean {

// GetTile at --time into -o TILE.exr (+ the PNG preview).
int tile(client::Client& client, const Request& r);
// StreamTiles from --t0 by --dt, --frames N, reassembled and written as -o DIR/frame_NNNNN.exr.
int stream(client::Client& client, const Request& r);
// SampleSurface at the --point / --points-file points, as CSV on stdout.
int sample(client::Client& client, const Request& r);

}  // namespace squall::cli::ocean
