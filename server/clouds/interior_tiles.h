// Tiles inside uniform density: for each tile (8^3 voxels of one value) of each lower internal node of a
// NanoVDB float grid, whether the tile and the 26 tiles around it hold the same value with no leaf among
// them. Density interpolated trilinearly is then that value throughout the tile (the 8 voxels around any
// point of it lie in those 27 tiles), and a ray marcher takes value x length through it with no sample.
//
// Layout, the same on host and device (kernels/clouds/node_walk.clh reads it): 128 words of 32 bits per lower
// node, the nodes in the order NanoVDB stores them; the tile at table index n of its node (n = x << 8 |
// y << 4 | z, its 8^3 cell in the node's 16^3) at bit n % 32 of word n / 32.
#pragma once

#include <nanovdb/NanoVDB.h>

#include <cstdint>
#include <vector>

namespace squall::clouds {

constexpr uint32_t kInteriorWordsPerLowerNode = 4096 / 32;

std::vector<uint32_t> interior_tiles(const nanovdb::FloatGrid& grid);

}  // namespace squall::clouds
