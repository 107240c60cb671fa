#include "clouds/interior_tiles.h"

namespace squall::clouds {
namespace {

using Lower = nanovdb::NanoLower<float>;
using Upper = nanovdb::NanoUpper<float>;

// A tile-sized cell of the 18^3 around a lower node (its 16^3 and a border of one): a tile's value, or no
// value where the cell is a leaf.
struct Cell {
  float value = 0;
  bool is_tile = false;
};

// The 18^3 cells around the lower node at `origin`, into `cells`: its own from its table, the border's
// through the accessor (a leaf of another node, or a tile of any level, or the background outside the tree).
void cells_around(const Lower& node, const nanovdb::Coord& origin, const nanovdb::DefaultReadAccessor<float>& acc,
                  std::vector<Cell>& cells) {
  cells.resize(18 * 18 * 18);
  for (int x = -1; x <= 16; ++x)
    for (int y = -1; y <= 16; ++y)
      for (int z = -1; z <= 16; ++z) {
        Cell& c = cells[((x + 1) * 18 + (y + 1)) * 18 + (z + 1)];
        if (x >= 0 && x < 16 && y >= 0 && y < 16 && z >= 0 && z < 16) {
          const uint32_t n = uint32_t(x) << 8 | uint32_t(y) << 4 | uint32_t(z);
          c.is_tile = !node.data()->isChild(n);
          if (c.is_tile) c.value = node.data()->getValue(n);
          continue;
        }
        const nanovdb::Coord ijk = origin + nanovdb::Coord(8 * x, 8 * y, 8 * z);
        c.is_tile = !acc.probeLeaf(ijk);
        if (c.is_tile) c.value = acc.getValue(ijk);
      }
}

// The interior bits of one lower node: its tiles whose 26 neighbours are tiles of their value.
void mark_interior(const std::vector<Cell>& cells, uint32_t* words) {
  auto at = [&](int x, int y, int z) -> const Cell& { return cells[((x + 1) * 18 + (y + 1)) * 18 + (z + 1)]; };
  for (int x = 0; x < 16; ++x)
    for (int y = 0; y < 16; ++y)
      for (int z = 0; z < 16; ++z) {
        const Cell& c = at(x, y, z);
        bool interior = c.is_tile;
        for (int dx = -1; dx <= 1 && interior; ++dx)
          for (int dy = -1; dy <= 1 && interior; ++dy)
            for (int dz = -1; dz <= 1 && interior; ++dz) {
              const Cell& n = at(x + dx, y + dy, z + dz);
              interior = n.is_tile && n.value == c.value;
            }
        const uint32_t n = uint32_t(x) << 8 | uint32_t(y) << 4 | uint32_t(z);
        if (interior) words[n / 32] |= 1u << (n % 32);
      }
}

}  // namespace

std::vector<uint32_t> interior_tiles(const nanovdb::FloatGrid& grid) {
  const auto& tree = grid.tree();
  const uint32_t lowers = tree.nodeCount(1);
  std::vector<uint32_t> words(size_t(lowers) * kInteriorWordsPerLowerNode, 0u);
  if (lowers == 0) return words;
  const Lower* first = tree.getFirstNode<1>();
  const auto acc = grid.getAccessor();
  std::vector<Cell> cells;
  // The lower nodes from the root down, so that each one's origin is its parent's table's (a node's own
  // origin() derives from its bounding box of active values).
  const auto* root = tree.root().data();
  for (uint32_t i = 0; i < root->mTableSize; ++i) {
    const auto* tile = root->tile(i);
    if (!tile->isChild()) continue;
    const Upper* upper = root->getChild(tile);
    for (uint32_t u = 0; u < Upper::SIZE; ++u) {
      if (!upper->data()->isChild(u)) continue;
      const Lower* lower = upper->data()->getChild(u);
      if (lower->data()->mChildMask.isOn()) continue;  // leaves only, no tile
      cells_around(*lower, tile->origin() + (Upper::OffsetToLocalCoord(u) << Lower::TOTAL), acc, cells);
      mark_interior(cells, &words[size_t(lower - first) * kInteriorWordsPerLowerNode]);
    }
  }
  return words;
}

}  // namespace squall::clouds
