// What a cloud build holds at its peak, bounded from the model before anything is built, so that the build
// is charged to --memory-budget before it starts.
//
// OpenVDB keeps a level set's narrow band in whole leaves of 8^3 voxels; converting a mesh holds a distance
// grid, a triangle index grid and masks over that band, and the stages after it a working copy and the
// device's NanoVDB copy of the same leaves. So a shape costs the voxels of its grown body rounded out to
// leaves (about a small shape that is a ball, not its area times the band's width), and each shape apart
// from the others the node tables above its leaves.
#pragma once

#include <cstdint>

#include "clouds/model.h"

namespace squall::clouds {

// Bytes held at the peak of a build of `model` (validated) at most: kBytesPerBandVoxel for each voxel of the
// shapes' grown bodies (leaves included), kBytesPerShape for each sphere, ellipsoid, particle and connected
// piece of a mesh, and kBytesPerBuild.
uint64_t build_bytes(const CloudModel& model);

// The peak per voxel of a grown body, measured at up to 12 bytes for meshes (distance, index and masks) and
// for pyroclastic layers (three copies of the band).
constexpr double kBytesPerBandVoxel = 16;
// OpenVDB's internal node tables about a shape far from the others (16^3 and 32^3 entries, in each grid).
constexpr double kBytesPerShape = 256 << 10;
// The build's fixed cost: grids' roots, the conversion's thread-local trees, the device upload.
constexpr double kBytesPerBuild = 32 << 20;

}  // namespace squall::clouds
