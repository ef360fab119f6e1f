#include "mapping/scan_inserter.h"

#include <cmath>

namespace dygslam {

void ScanInserter::Insert(octomap::OcTree& tree, const octomap::Pointcloud& scan,
                          const octomap::point3d& origin, double max_range, bool lazy_eval) {
  if (!Collect(tree, scan, origin, max_range)) {
    ClearMarks();
    ++fallback_scans_;
    tree.insertPointCloud(scan, origin, max_range, lazy_eval, /*discretize=*/false);
    return;
  }
  // As insertPointCloud: the free cells that are not also occupied, then the occupied ones.
  for (const octomap::OcTreeKey& key : free_) {
    if (marks_[Index(key)] == kFree) UpdateCell(tree, key, false, lazy_eval);
  }
  for (const octomap::OcTreeKey& key : occupied_) UpdateCell(tree, key, true, lazy_eval);
  ClearMarks();
  ++grid_scans_;
}

bool ScanInserter::Collect(const octomap::OcTree& tree, const octomap::Pointcloud& scan,
                           const octomap::point3d& origin, double max_range) {
  if (max_range <= 0 || tree.bbxSet()) return false;
  // Every cell of a ray lies in the box of its two ends, which are at most max_range apart
  // (+1 cell for a ray's end on a cell border, +1 spare).
  const double cells = std::ceil(max_range / tree.getResolution()) + 2;
  if (!(cells <= kMaxHalfSideCells)) return false;
  if (!tree.coordToKeyChecked(origin, center_)) return false;
  const int half = static_cast<int>(cells);
  if (half != half_) {
    half_ = half;
    side_ = 2 * half + 1;
    marks_.assign(static_cast<size_t>(side_) * side_ * side_, kUnseen);
  }
  auto mark_free = [&](const octomap::KeyRay& ray) {
    for (const octomap::OcTreeKey& key : ray) {
      const int64_t i = Index(key);
      if (i < 0) return false;
      if (marks_[i] == kUnseen) {
        marks_[i] = kFree;
        free_.push_back(key);
      }
    }
    return true;
  };
  for (size_t n = 0; n < scan.size(); ++n) {
    const octomap::point3d& p = scan[n];
    // The same arithmetic as OccupancyOcTreeBase::computeUpdate, so the same rays.
    if ((p - origin).norm() <= max_range) {
      if (tree.computeRayKeys(origin, p, ray_) && !mark_free(ray_)) return false;
      octomap::OcTreeKey key;
      if (tree.coordToKeyChecked(p, key)) {
        const int64_t i = Index(key);
        if (i < 0) return false;
        if (marks_[i] != kOccupied) {
          marks_[i] = kOccupied;
          occupied_.push_back(key);
        }
      }
    } else {
      const octomap::point3d direction = (p - origin).normalized();
      const octomap::point3d new_end = origin + direction * static_cast<float>(max_range);
      if (tree.computeRayKeys(origin, new_end, ray_) && !mark_free(ray_)) return false;
    }
  }
  return true;
}

void ScanInserter::UpdateCell(octomap::OcTree& tree, const octomap::OcTreeKey& key, bool occupied,
                              bool lazy_eval) {
  octomap::OcTreeNode* node = tree.getRoot();
  if (!lazy_eval || node == nullptr || tree.isChangeDetectionEnabled()) {
    tree.updateNode(key, occupied, lazy_eval);
    return;
  }
  // OcTree::updateNode in one descent instead of two. It first searches the key's deepest node
  // and leaves a cell alone whose value is already clamped in the update's direction; then it
  // descends again, expanding pruned nodes and creating missing ones, and updates the leaf.
  const float update = occupied ? tree.getProbHitLog() : tree.getProbMissLog();
  auto clamped = [&](const octomap::OcTreeNode* leaf) {
    return (update >= 0 && leaf->getLogOdds() >= tree.getClampingThresMaxLog()) ||
           (update <= 0 && leaf->getLogOdds() <= tree.getClampingThresMinLog());
  };
  const int depth = static_cast<int>(tree.getTreeDepth());
  bool searched = false;      // the search's node was found (and was not clamped)
  bool just_created = false;  // `node` was created by this update
  for (int level = 0; level < depth; ++level) {
    const unsigned int child = octomap::computeChildIdx(key, depth - 1 - level);
    if (!tree.nodeChildExists(node, child)) {
      if (!tree.nodeHasChildren(node) && !just_created) {
        // A leaf above full depth (pruned): the search ends here, then it is expanded.
        if (!searched && clamped(node)) return;
        tree.expandNode(node);
      } else {
        tree.createNodeChild(node, child);
        just_created = true;
      }
      searched = true;  // the search ended at this level (a pruned leaf, or not found)
    }
    node = tree.getNodeChild(node, child);
  }
  if (!searched && clamped(node)) return;
  tree.updateNodeLogOdds(node, update);
}

int64_t ScanInserter::Index(const octomap::OcTreeKey& key) const {
  int64_t index = 0;
  for (int axis = 0; axis < 3; ++axis) {
    const int offset = static_cast<int>(key[axis]) - static_cast<int>(center_[axis]) + half_;
    if (offset < 0 || offset >= side_) return -1;
    index = index * side_ + offset;
  }
  return index;
}

void ScanInserter::ClearMarks() {
  for (const octomap::OcTreeKey& key : free_) marks_[Index(key)] = kUnseen;
  for (const octomap::OcTreeKey& key : occupied_) marks_[Index(key)] = kUnseen;
  free_.clear();
  occupied_.clear();
}

}  // namespace dygslam
