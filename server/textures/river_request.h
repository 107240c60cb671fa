// squall.v1 river messages <-> the river engine's structs (RiverVelocity, BakeVelocityRequest and
// BakeVelocityReply). Part of squall_rpc (includes the protos).
#pragma once

#include <string>

#include "squall/v1/textures.pb.h"
#include "textures/river.h"

namespace squall::textures::rpc {

// The river; its optional fields unset stay unset (the engine's defaults). Range checks happen in
// RiverEngine::validate under the same path.
RiverSpec river(const squall::v1::RiverVelocity& river);

// BakeVelocity's grid (nx, ny, region; the region required).
BakeGrid bake_grid(const squall::v1::BakeVelocityRequest& request, const std::string& path = "request");
// The grid a river driving an advection is baked on: bake_nx x bake_ny (default 128) over bake_region,
// default the output region.
BakeGrid bake_grid(const squall::v1::RiverVelocity& river, const OutputSpec& output);

void fill_bake(const RiverBake& bake, const squall::v1::BakeVelocityRequest& request,
               squall::v1::BakeVelocityReply* reply);

}  // namespace squall::textures::rpc
