// Comparing occupancy maps: ghost voxels (dynamic objects baked into the static map) and counting
// helpers. All counts are in cells of the maps' resolution: a pruned leaf of size 2^k * res counts
// as 8^k cells.
#pragma once

#include <octomap/OcTree.h>

#include <cstdint>
#include <functional>
#include <vector>

namespace dygslam {

struct GhostVoxelCounts {
  uint64_t occupied_in_a = 0;
  // Occupied in A, observed free in B: ghosts of A (e.g. people baked into the map).
  uint64_t occupied_a_free_b = 0;
  // Of those, cells with no occupied cell of B within `surface_margin_cells` (26-neighbourhood):
  // ghosts proper. Depth noise and grazing rays make surface cells flip between occupied and
  // free from one frame set to the next; this count leaves that jitter out.
  uint64_t ghost = 0;
  // Occupied in A, occupied in B too (agreed structure).
  uint64_t occupied_a_occupied_b = 0;
  // Occupied in A, never observed in B (no verdict).
  uint64_t occupied_a_unknown_b = 0;
  uint64_t occupied_in_b = 0;
  // Occupied in B, observed free in A: static structure A lost (over-filtering or clearing).
  uint64_t occupied_b_free_a = 0;

  double GhostFraction() const {
    return occupied_in_a == 0 ? 0.0 : static_cast<double>(ghost) / occupied_in_a;
  }
};

// `a`: map under test (e.g. built from all frames); `b`: reference (e.g. people-free frames).
// Both maps must have the same resolution (throws std::invalid_argument otherwise); cells are
// compared by octree key, so the grids coincide exactly.
// surface_margin_cells >= 0 (0: ghost == occupied_a_free_b). ghost_cells, if given, receives the
// centres of the ghost cells.
GhostVoxelCounts CompareGhostVoxels(const octomap::OcTree& a, const octomap::OcTree& b,
                                    int surface_margin_cells = 1,
                                    std::vector<octomap::point3d>* ghost_cells = nullptr);

// Number of occupied (resp. observed free) cells whose centre satisfies `inside`.
uint64_t CountOccupiedInside(const octomap::OcTree& map,
                             const std::function<bool(const octomap::point3d&)>& inside);
uint64_t CountFreeInside(const octomap::OcTree& map,
                         const std::function<bool(const octomap::point3d&)>& inside);

// Occupancy of the cell containing `point`: +1 occupied, 0 free, -1 unknown.
int CellState(const octomap::OcTree& map, const octomap::point3d& point);

// Calls `visit(centre, occupied)` for every known cell (leaves expanded to the finest resolution).
void ForEachCell(const octomap::OcTree& map,
                 const std::function<void(const octomap::point3d&, bool occupied)>& visit);

}  // namespace dygslam
