// squall.v1 Clouds messages <-> the clouds engine's structs: published defaults for unset optional fields,
// and field paths for the engine's validation messages. Part of squall_rpc (includes the protos).
#pragma once

#include <string>

#include "clouds/cloud_engine.h"
#include "clouds/evolution.h"
#include "squall/v1/clouds.pb.h"

namespace squall::clouds::rpc {

// Translates; structural problems (a mesh with both obj and vertices, a bad OBJ) throw InvalidArgument
// naming the field. Range checks happen in clouds::validate with the same field paths.
CloudModel model(const squall::v1::CloudModel& m, const std::string& field = "model");
// Bytes the model's meshes take while they are read and checked (clouds::mesh_read_bytes), counted from the
// request alone, so that they can be reserved before model() reads them.
uint64_t mesh_read_bytes(const squall::v1::CloudModel& m);
RenderSettings settings(const squall::v1::RenderSettings& s, const std::string& field = "settings");
Evolution evolution(const squall::v1::EvolutionSpec& e);

void fill_summary(const StoredVolume& volume, squall::v1::VolumeSummary* out);
void fill_image(const Image& image, squall::v1::CloudImage* out);
uint64_t image_bytes(const RenderSettings& settings);  // the CloudImage's data bytes

}  // namespace squall::clouds::rpc
