// squall.v1 EWave messages <-> the engine's structs (ewave_config.h). Every request field is checked here
// with its proto field path in the message ("inputs.obstruction.nx = 10, want the session's nx = 64");
// the engine's own validation (finite values, ranges) uses the same paths. Part of squall_rpc.
#pragma once

#include <string>

#include "common/limits.h"
#include "ewave/ewave_config.h"
#include "squall/v1/ewave.pb.h"

namespace squall::ewave::rpc {

// The engine config of a request's config ("config"); grid checked against --max-grid-cells.
EWaveConfig config(const squall::v1::EWaveConfig& proto, const LimitGate& gate);
// The proto form of an engine config, optionals filled in, initial fields left out.
void fill_config(const EWaveConfig& config, squall::v1::EWaveConfig* proto);

// One step's inputs for a session of `config` ("inputs").
StepInputs inputs(const squall::v1::EWaveInputs& proto, const EWaveConfig& config, const LimitGate& gate);

// The request's retry_key (at most kMaxRetryKeyBytes: InvalidArgument naming "retry_key") and after_step, for
// the session of serial `session_serial` (EWaveEngine::view).
StepGuard guard(const squall::v1::EWaveStepRequest& request, uint64_t session_serial);

// The validated output list of inputs (empty: height only). The reply's element type is checked by
// squall::field::dtype (common/field_codec.h).
std::vector<squall::v1::EWaveOutput> outputs(const squall::v1::EWaveInputs& proto);

// Bytes of a frame with these outputs (a bound, for --max-message-bytes).
uint64_t frame_bytes(const EWaveConfig& config, size_t outputs, squall::v1::DType dtype);
// Host bytes a step's Frame holds for `o` before it is encoded: a float plane each for h and phi (read as
// doubles first in a double session), two for the displacement, three for the normals and one for the
// normal component being encoded.
uint64_t frame_host_bytes(const EWaveConfig& config, const OutputSelection& o);

// The reply frame of an engine frame: one Field per output, in order.
void fill_frame(const Frame& frame, const EWaveConfig& config, const std::vector<squall::v1::EWaveOutput>& outputs,
                squall::v1::DType dtype, squall::v1::EWaveFrame* reply);

// The values of an nx x ny Field (float32 or float16) for a grid of nx x ny; InvalidArgument naming
// `path` on a wrong shape, dtype or byte count.
std::vector<float> grid_values(const squall::v1::Field& field, int64_t nx, int64_t ny, const std::string& path);

}  // namespace squall::ewave::rpc
