// squall.v1 Ocean messages <-> the engine's structs (ocean_params.h). The translation maps enums and
// optional fields; the ranges are the engine's (validate_tile), checked under the request's field path
// ("tile.layers[1].wind_speed = nan must be finite and in (0, 100]"). Part of squall_rpc.
#pragma once

#include <string>
#include <vector>

#include "common/cancel.h"
#include "common/limits.h"
#include "ocean/ocean_params.h"
#include "squall/v1/ocean.pb.h"

namespace squall::ocean::rpc {

// The engine spec of a request's tile (field path prefix `path`, e.g. "tile"). Throws squall::Error:
// InvalidArgument naming the field, ResourceExhausted for grids beyond --max-grid-cells.
// A SimTime's seconds: finite and within +-1e9 s (INVALID_ARGUMENT naming `path`).
double sim_time(const std::string& path, double seconds);

TileSpec tile_spec(const squall::v1::TileSpec& tile, const LimitGate& gate, const std::string& path = "tile");

// The outputs asked for, validated (at least one, each known, none twice).
std::vector<squall::v1::TileOutput> outputs(const google::protobuf::RepeatedField<int>& outputs,
                                            const std::string& path = "outputs");
unsigned output_flags(const std::vector<squall::v1::TileOutput>& outputs);   // engine Output bits
unsigned output_planes(const std::vector<squall::v1::TileOutput>& outputs);  // engine kAllPlanes bits
int output_plane(squall::v1::TileOutput output);                             // its kAllPlanes bit index

// Output grid of a validated spec (the first layer's when the spec leaves it 0).
void output_grid(const TileSpec& spec, int64_t* nx, int64_t* ny);

// The Field of one output of a computed tile, as GetTile returns it (name, unit, grid, dtype, bytes;
// encoded by common/field_codec.h, which also checks the request's dtype: squall::field::dtype).
void fill_field(const TileFields& tile, squall::v1::TileOutput output, squall::v1::DType dtype,
                squall::v1::Field* field);

// The Fields of `outputs`, in their order, appended to `fields` (fill_field). `cancel` is looked at before
// each, as a 4096^2 plane is 64 MiB to encode: Error(Cancelled) naming the output's index in `outputs`.
void fill_fields(const TileFields& tile, const std::vector<squall::v1::TileOutput>& outputs, squall::v1::DType dtype,
                 const Cancellation& cancel, google::protobuf::RepeatedPtrField<squall::v1::Field>* fields);

}  // namespace squall::ocean::rpc
