#include "mapping/map_compare.h"

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

namespace dygslam {
namespace {

// Visits every finest-resolution key covered by the leaf at `it`.
template <typename Fn>
void ForEachKeyOfLeaf(const octomap::OcTree& map, const octomap::OcTree::leaf_iterator& it,
                      Fn&& fn) {
  const unsigned depth = it.getDepth();
  const unsigned max_depth = map.getTreeDepth();
  if (depth == max_depth) {
    fn(it.getKey());
    return;
  }
  // A leaf at depth d covers 2^(max_depth - d) keys per axis starting at the aligned key.
  const unsigned span = 1u << (max_depth - depth);
  const octomap::OcTreeKey base = it.getIndexKey();
  for (unsigned dx = 0; dx < span; ++dx) {
    for (unsigned dy = 0; dy < span; ++dy) {
      for (unsigned dz = 0; dz < span; ++dz) {
        fn(octomap::OcTreeKey(base[0] + dx, base[1] + dy, base[2] + dz));
      }
    }
  }
}

// -1 unknown, 0 free, 1 occupied.
int KeyState(const octomap::OcTree& map, const octomap::OcTreeKey& key) {
  const octomap::OcTreeNode* node = map.search(key);
  if (node == nullptr) return -1;
  return map.isNodeOccupied(node) ? 1 : 0;
}

bool OccupiedNear(const octomap::OcTree& map, const octomap::OcTreeKey& key, int margin) {
  for (int dx = -margin; dx <= margin; ++dx) {
    for (int dy = -margin; dy <= margin; ++dy) {
      for (int dz = -margin; dz <= margin; ++dz) {
        const octomap::OcTreeKey k(static_cast<uint16_t>(key[0] + dx),
                                   static_cast<uint16_t>(key[1] + dy),
                                   static_cast<uint16_t>(key[2] + dz));
        if (KeyState(map, k) == 1) return true;
      }
    }
  }
  return false;
}

}  // namespace

GhostVoxelCounts CompareGhostVoxels(const octomap::OcTree& a, const octomap::OcTree& b,
                                    int surface_margin_cells,
                                    std::vector<octomap::point3d>* ghost_cells) {
  if (ghost_cells != nullptr) ghost_cells->clear();
  if (surface_margin_cells < 0 || surface_margin_cells > 10) {
    throw std::invalid_argument("CompareGhostVoxels: surface_margin_cells must be in [0, 10]");
  }
  if (std::abs(a.getResolution() - b.getResolution()) > 1e-9) {
    throw std::invalid_argument("CompareGhostVoxels: maps differ in resolution (" +
                                std::to_string(a.getResolution()) + " vs " +
                                std::to_string(b.getResolution()) + ")");
  }
  GhostVoxelCounts counts;
  for (auto it = a.begin_leafs(), end = a.end_leafs(); it != end; ++it) {
    if (!a.isNodeOccupied(*it)) continue;
    ForEachKeyOfLeaf(a, it, [&](const octomap::OcTreeKey& key) {
      ++counts.occupied_in_a;
      switch (KeyState(b, key)) {
        case 1:
          ++counts.occupied_a_occupied_b;
          break;
        case 0:
          ++counts.occupied_a_free_b;
          if (!OccupiedNear(b, key, surface_margin_cells)) {
            ++counts.ghost;
            if (ghost_cells != nullptr) ghost_cells->push_back(a.keyToCoord(key));
          }
          break;
        default:
          ++counts.occupied_a_unknown_b;
          break;
      }
    });
  }
  for (auto it = b.begin_leafs(), end = b.end_leafs(); it != end; ++it) {
    if (!b.isNodeOccupied(*it)) continue;
    ForEachKeyOfLeaf(b, it, [&](const octomap::OcTreeKey& key) {
      ++counts.occupied_in_b;
      if (KeyState(a, key) == 0) ++counts.occupied_b_free_a;
    });
  }
  return counts;
}

void ForEachCell(const octomap::OcTree& map,
                 const std::function<void(const octomap::point3d&, bool occupied)>& visit) {
  for (auto it = map.begin_leafs(), end = map.end_leafs(); it != end; ++it) {
    const bool occupied = map.isNodeOccupied(*it);
    ForEachKeyOfLeaf(map, it,
                     [&](const octomap::OcTreeKey& key) { visit(map.keyToCoord(key), occupied); });
  }
}

uint64_t CountOccupiedInside(const octomap::OcTree& map,
                             const std::function<bool(const octomap::point3d&)>& inside) {
  uint64_t count = 0;
  ForEachCell(map, [&](const octomap::point3d& centre, bool occupied) {
    if (occupied && inside(centre)) ++count;
  });
  return count;
}

uint64_t CountFreeInside(const octomap::OcTree& map,
                         const std::function<bool(const octomap::point3d&)>& inside) {
  uint64_t count = 0;
  ForEachCell(map, [&](const octomap::point3d& centre, bool occupied) {
    if (!occupied && inside(centre)) ++count;
  });
  return count;
}

int CellState(const octomap::OcTree& map, const octomap::point3d& point) {
  octomap::OcTreeKey key;
  if (!map.coordToKeyChecked(point, key)) return -1;
  return KeyState(map, key);
}

}  // namespace dygslam
