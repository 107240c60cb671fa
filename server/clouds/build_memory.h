// What a cloud build holds at its peak, bounded from the model before anything is built, so that the build
// is charged to --memory-budget before it starts.
//
// OpenVDB keeps a level set's narrow band in whole leaves of 8^3 voxels (the inside as tiles); converting a
// mesh holds a distance grid, a triangle index grid and masks over that band, and the stages after it a
// working copy and the device's NanoVDB copy of the same leaves. So a shape costs the voxels of its body
// grown by the band, rounded out to leaves (about a small shape that is a ball, not its area times the
// band's width), and the internal nodes above those leaves: tables of 16^3 and 32^3 entries in each grid.
#pragma once

#include <cstdint>

#include "clouds/model.h"

namespace squall::clouds {

// Bytes held at the peak of a build of `model` (validated) at most: kBytesPerBandVoxel for each voxel of
// each shape's grown body (a sphere, ellipsoid, particle or connected piece of a mesh; a piece that is not
// convex, its whole grown bounding box), and kTemperatureBytesPerVoxel more with a temperature field; the
// internal nodes those bodies reach in kGridsAtPeak grids; kBytesPerTriangle for each mesh triangle and
// kBytesPerVertex for each vertex; and kBytesPerBuild. UINT64_MAX past 2^64. Not bounded: the per-thread
// grids of OpenVDB's mesh conversion, which copy the leaves that the triangles of several threads' shares
// reach (base_level_set hands it a mesh's triangles in Z order and an ellipsoid's in rings along its
// longest axis, so that shares are regions).
// `pieces`: its meshes' connected pieces, as validate() gives them; the other form computes them.
uint64_t build_bytes(const CloudModel& model, const std::vector<MeshPiece>& pieces);
uint64_t build_bytes(const CloudModel& model);

// Bytes a mesh of `vertices` vertices and `triangles` triangles takes while it is read from a request and
// checked, at most: the model's two copies and validate's welded copy, vertex sets, piece labels and edge table.
// Its counts are known before it is read (count_obj), so that reading it is charged to --memory-budget first.
uint64_t mesh_read_bytes(uint64_t vertices, uint64_t triangles);

// The peak per voxel of a grown body: measured at up to 12 bytes for meshes (distance, index and masks) and
// for pyroclastic layers (three copies of the band).
constexpr double kBytesPerBandVoxel = 16;
// A temperature grid and its device copy, as many voxels as the density.
constexpr double kTemperatureBytesPerVoxel = 8;
// A mesh triangle: its indices in the model and OpenVDB's copies of them.
constexpr double kBytesPerTriangle = 128;
// A mesh vertex, referenced or not: the model's (3 doubles) and OpenVDB's (3 floats).
constexpr double kBytesPerVertex = 36;
// OpenVDB's internal nodes: a lower one's 16^3 entries of 8 bytes and its two masks, an upper one's 32^3;
// the grids alive at the peak hold them: the conversion's distance, index and mask grids, the level set,
// density and NanoVDB grids, and the NanoVDB grid's interior_tiles (512 bytes a lower node; a shape alone in
// its upper node measured 2.7 MB).
constexpr double kLowerNodeBytes = 16 * 16 * 16 * 8 + 2 * 512, kUpperNodeBytes = 32 * 32 * 32 * 8 + 2 * 4096;
constexpr double kGridsAtPeak = 10;
// Reading and checking a mesh, as measured (up to 0.83 of it): per vertex the model's two copies (the read
// one and the engine's) and the welded copy's position, the weld's hash table and the vertex sets; per
// triangle the copies' indices, its piece and its share of the edge table (a node per edge, three halves
// of an edge per triangle).
constexpr double kReadBytesPerVertex = 192, kReadBytesPerTriangle = 112;
// The build's fixed cost: grids' roots, the conversion's thread-local trees, the device upload.
constexpr double kBytesPerBuild = 32 << 20;

}  // namespace squall::clouds
