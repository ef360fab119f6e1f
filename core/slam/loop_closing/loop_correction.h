// Loop correction, the third step of loop closing, under the map lock: the keyframe and its
// covisible neighbours are moved by the loop transform (and their points with them), duplicated
// map points are fused, covisibility is updated, the essential graph (spanning tree, strong
// covisibility, loop edges) is optimised with Ceres, and map points follow their reference
// keyframes. A correction below `pose_graph_min_correction_*` moves nothing: only the fusion and
// the links are made. A loop whose map state changed since its checks is dropped.
#pragma once

#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include "core/slam/loop_closing/loop_closing_options.h"
#include "core/slam/loop_closing/loop_verification.h"
#include "core/slam/map/map.h"
#include "core/slam/feature/matcher.h"

namespace dygslam {

struct LoopCorrection {
  bool applied = false;        // false: dropped (a keyframe culled or the map corrected meanwhile)
  bool fused_only = false;     // below pose_graph_min_correction_*: nothing moved
  int fused = 0;               // map points fused
  double shift_m = 0;          // how far the current keyframe moved
  std::vector<int64_t> moved;  // keyframes whose pose changed
  size_t loop_edges = 0;       // loop edges kept after this loop
};

// Applies accepted loops to the map and keeps the loop edges for later pose graphs, between
// active keyframes (a culled keyframe's id replaced by the active one that took its place), each
// pair once. Not thread-safe: one thread corrects; LoopEdges() may be called from any.
class LoopCorrector {
 public:
  LoopCorrector(std::shared_ptr<Map> map, const LoopClosingOptions& options,
                const MatcherOptions& matcher);

  // Takes the map lock.
  LoopCorrection Apply(const std::shared_ptr<KeyFrame>& kf, const LoopMatch& loop);
  // Takes the map lock.
  std::vector<std::pair<int64_t, int64_t>> LoopEdges() const;

 private:
  // Steps of Apply; the map lock is held.
  std::vector<std::shared_ptr<KeyFrame>> LoopGroup(const std::shared_ptr<KeyFrame>& kf,
                                                   const LoopMatch& loop) const;
  int FuseLoopPoints(const std::shared_ptr<KeyFrame>& kf, const LoopMatch& loop,
                     const std::vector<std::shared_ptr<KeyFrame>>& group) const;
  std::vector<std::pair<int64_t, int64_t>> LinkAfterFusion(
      const std::shared_ptr<KeyFrame>& kf, const LoopMatch& loop,
      const std::vector<std::shared_ptr<KeyFrame>>& group) const;
  void OptimizeEssentialGraph(const LoopMatch& loop,
                              const std::vector<std::pair<int64_t, int64_t>>& new_links,
                              const std::map<int64_t, Rigid3d>& uncorrected,
                              std::vector<int64_t>* moved);
  void AddLoopEdges(const std::vector<std::pair<int64_t, int64_t>>& links);
  void CompactLoopEdges();

  std::shared_ptr<Map> map_;
  LoopClosingOptions options_;
  Matcher matcher_;
  std::vector<std::pair<int64_t, int64_t>> loop_edges_;  // map lock held
};

}  // namespace dygslam
