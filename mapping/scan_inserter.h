// One depth scan into an octomap::OcTree: the cells and updates of
// octomap::OccupancyOcTreeBase::insertPointCloud (no discretisation, no bounding box), with the
// cells of the scan collected in a dense grid around the sensor instead of two hash sets.
//
// insertPointCloud gathers the free cells of every ray and the occupied end cells in
// std::unordered_sets: on the Bonn keyframes (~10^4 points, ~4 * 10^5 ray cells) inserting,
// rehashing and freeing those sets is about half of the insertion's CPU. Here a ray cell is marked
// in a byte grid that covers the sensor's range (max_range / resolution cells each way; 4.5 MB
// for 4 m at 5 cm) and kept in a list the first time it is seen; the grid is cleared through the
// lists. Each cell gets one update per scan as in OctoMap (occupied wins over free), and the update
// descends the tree once where OcTree::updateNode descends twice (a search for its early exit on a
// clamped cell, then the update), so the tree is the same as insertPointCloud's, node for node. A
// range too large for the grid (more than 128 cells each way), a bounding box set on the tree or a
// cell outside the grid fall back to insertPointCloud itself.
#pragma once

#include <octomap/OcTree.h>

#include <cstdint>
#include <vector>

namespace dygslam {

class ScanInserter {
 public:
  // Ray cells from the sensor further than this many cells each way fall back (see above).
  static constexpr int kMaxHalfSideCells = 128;

  // Updates `tree` with `scan` (world frame) seen from `origin`, as
  // tree.insertPointCloud(scan, origin, max_range, lazy_eval, /*discretize=*/false).
  void Insert(octomap::OcTree& tree, const octomap::Pointcloud& scan,
              const octomap::point3d& origin, double max_range, bool lazy_eval);

  // Scans inserted through the grid and through insertPointCloud (the fallback).
  int64_t grid_scans() const { return grid_scans_; }
  int64_t fallback_scans() const { return fallback_scans_; }

 private:
  enum Mark : uint8_t { kUnseen = 0, kFree = 1, kOccupied = 2 };
  bool Collect(const octomap::OcTree& tree, const octomap::Pointcloud& scan,
               const octomap::point3d& origin, double max_range);
  // tree.updateNode(key, occupied, lazy_eval), with one descent of the tree instead of two.
  static void UpdateCell(octomap::OcTree& tree, const octomap::OcTreeKey& key, bool occupied,
                         bool lazy_eval);
  // Index of `key` in the grid centred on center_, or -1 outside it.
  int64_t Index(const octomap::OcTreeKey& key) const;
  void ClearMarks();

  std::vector<uint8_t> marks_;
  int half_ = 0;  // cells each way from the centre
  int side_ = 0;  // 2 * half_ + 1
  octomap::OcTreeKey center_;
  octomap::KeyRay ray_;
  std::vector<octomap::OcTreeKey> free_;
  std::vector<octomap::OcTreeKey> occupied_;
  int64_t grid_scans_ = 0;
  int64_t fallback_scans_ = 0;
};

}  // namespace dygslam
