#include "core/slam/loop_closing/loop_correction.h"

#include <algorithm>
#include <map>
#include <set>

#include "core/base/log.h"
#include "core/slam/optimize/pose_graph.h"

namespace dygslam {

namespace {

// `edges` with every id replaced by the active keyframe that stands for it; edges whose ends fall
// on one keyframe (or on none) dropped, each pair once. Map lock held.
std::vector<std::pair<int64_t, int64_t>> ResolveLoopEdges(
    const Map& map, const std::vector<std::pair<int64_t, int64_t>>& edges) {
  std::set<std::pair<int64_t, int64_t>> kept;
  std::vector<std::pair<int64_t, int64_t>> resolved;
  for (const auto& [a, b] : edges) {
    const int64_t i = map.ActiveKeyFrameId(a), j = map.ActiveKeyFrameId(b);
    if (i < 0 || j < 0 || i == j) continue;
    if (kept.insert(std::minmax(i, j)).second) resolved.push_back({i, j});
  }
  return resolved;
}

// Moves the keyframes of `group` to `corrected` and their map points with them (each point once,
// by the first keyframe of the group that sees it). Map lock held.
void MoveGroup(Map& map, const std::vector<std::shared_ptr<KeyFrame>>& group,
               const std::map<int64_t, Rigid3d>& uncorrected,
               const std::map<int64_t, Rigid3d>& corrected) {
  std::set<int64_t> moved_points;
  std::vector<std::shared_ptr<MapPoint>> touched;
  for (const auto& g : group) {
    const Rigid3d world_from_new = corrected.at(g->id).Inverse();
    for (const auto& mp : g->map_points) {
      if (!mp || mp->bad || !moved_points.insert(mp->id).second) continue;
      mp->position = world_from_new * (uncorrected.at(g->id) * mp->position);
      touched.push_back(mp);
    }
  }
  for (const auto& g : group) g->cam_from_world = corrected.at(g->id);
  for (const auto& mp : touched) map.UpdateNormalAndDepth(*mp);
}

// Every point follows its reference keyframe (or the first observing keyframe with a pose) from
// `before` to `after`. Map lock held.
void PointsFollowKeyFrames(Map& map, const std::map<int64_t, Rigid3d>& before,
                           const std::map<int64_t, Rigid3d>& after) {
  for (const auto& [pid, mp] : map.map_points()) {
    if (mp->bad) continue;
    int64_t ref = mp->ref_kf_id;
    if (!after.count(ref)) {
      ref = -1;
      for (const auto& [kid, idx] : mp->observations)
        if (after.count(kid)) {
          ref = kid;
          break;
        }
    }
    if (ref < 0) continue;
    mp->position = after.at(ref).Inverse() * (before.at(ref) * mp->position);
    map.UpdateNormalAndDepth(*mp);
  }
}

}  // namespace

LoopCorrector::LoopCorrector(std::shared_ptr<Map> map, const LoopClosingOptions& options,
                             const MatcherOptions& matcher)
    : map_(std::move(map)), options_(options), matcher_(matcher) {}

void LoopCorrector::CompactLoopEdges() { loop_edges_ = ResolveLoopEdges(*map_, loop_edges_); }

std::vector<std::pair<int64_t, int64_t>> LoopCorrector::LoopEdges() const {
  std::lock_guard<std::mutex> lock(map_->mutex());
  return ResolveLoopEdges(*map_, loop_edges_);
}

void LoopCorrector::AddLoopEdges(const std::vector<std::pair<int64_t, int64_t>>& links) {
  for (const auto& l : links) loop_edges_.push_back(l);
  CompactLoopEdges();
}

// The current keyframe and its covisible neighbours, but not the loop side: a revisit (loop
// keyframe covisible with the current one) must not move the loop side.
std::vector<std::shared_ptr<KeyFrame>> LoopCorrector::LoopGroup(const std::shared_ptr<KeyFrame>& kf,
                                                                const LoopMatch& loop) const {
  std::set<int64_t> loop_side = {loop.loop_kf->id};
  for (const auto& [id, w] : loop.loop_kf->connection_weights) loop_side.insert(id);
  std::vector<std::shared_ptr<KeyFrame>> group = {kf};
  for (int64_t id : kf->ordered_connections) {
    if (loop_side.count(id)) continue;
    auto n = map_->GetKeyFrame(id);
    if (n && !n->bad) group.push_back(n);
  }
  return group;
}

// The loop's matched points replace the current keyframe's duplicates, then the loop
// neighbourhood's points are fused into every keyframe of the group. Returns the fused count.
int LoopCorrector::FuseLoopPoints(const std::shared_ptr<KeyFrame>& kf, const LoopMatch& loop,
                                  const std::vector<std::shared_ptr<KeyFrame>>& group) const {
  int fused = 0;
  for (size_t i = 0; i < loop.matches.size(); ++i) {
    const auto& lp = loop.matches[i];
    if (!lp || lp->bad) continue;
    const auto current = kf->map_points[i];
    if (current && !current->bad) {
      if (current != lp) {
        map_->Replace(current, lp);
        ++fused;
      }
    } else if (lp->observations.count(kf->id) == 0) {
      map_->AddObservation(lp, kf, static_cast<int>(i));
      map_->ComputeDistinctiveDescriptor(*lp);
      ++fused;
    }
  }
  for (const auto& g : group)
    fused += matcher_.Fuse(*map_, g, loop.loop_points, options_.fusion_radius_px);
  return fused;
}

// Covisibility after fusion; the links that appeared between the two sides, and the loop itself,
// are the new loop edges.
std::vector<std::pair<int64_t, int64_t>> LoopCorrector::LinkAfterFusion(
    const std::shared_ptr<KeyFrame>& kf, const LoopMatch& loop,
    const std::vector<std::shared_ptr<KeyFrame>>& group) const {
  std::set<int64_t> group_ids;
  for (const auto& g : group) group_ids.insert(g->id);
  std::map<int64_t, std::set<int64_t>> before;
  for (const auto& g : group)
    for (const auto& [id, w] : g->connection_weights) before[g->id].insert(id);
  for (const auto& g : group) map_->UpdateConnections(g);
  std::vector<std::pair<int64_t, int64_t>> new_links;
  for (const auto& g : group) {
    for (const auto& [id, w] : g->connection_weights) {
      if (group_ids.count(id) || before[g->id].count(id)) continue;
      new_links.push_back({g->id, id});
    }
  }
  new_links.push_back({kf->id, loop.loop_kf->id});
  return new_links;
}

// Essential graph: spanning tree, strong covisibility and old loop edges measured from the poses
// before this correction, the new loop links from the corrected ones; keyframes take the
// optimised poses and points follow their reference keyframe.
void LoopCorrector::OptimizeEssentialGraph(
    const LoopMatch& loop, const std::vector<std::pair<int64_t, int64_t>>& new_links,
    const std::map<int64_t, Rigid3d>& uncorrected, std::vector<int64_t>* moved) {
  std::map<int64_t, Rigid3d> poses, measure;
  for (const auto& [id, k] : map_->keyframes()) {
    poses[id] = k->cam_from_world;
    auto u = uncorrected.find(id);
    measure[id] = u != uncorrected.end() ? u->second : k->cam_from_world;
  }
  std::vector<PoseGraphEdge> edges;
  std::set<std::pair<int64_t, int64_t>> added;
  auto add = [&](int64_t i, int64_t j, const std::map<int64_t, Rigid3d>& from) {
    if (!poses.count(i) || !poses.count(j) || i == j) return;
    if (!added.insert(std::minmax(i, j)).second) return;
    edges.push_back({i, j, from.at(i) * from.at(j).Inverse(), 1.0});
  };
  for (const auto& [a, b] : new_links) add(a, b, poses);
  CompactLoopEdges();
  for (const auto& [a, b] : loop_edges_) add(a, b, measure);
  for (const auto& [id, k] : map_->keyframes()) {
    if (k->parent_id >= 0) add(id, k->parent_id, measure);
    for (const auto& [other, w] : k->connection_weights)
      if (w >= options_.essential_min_weight) add(id, other, measure);
  }
  AddLoopEdges(new_links);
  const std::set<int64_t> fixed = {loop.loop_kf->id, map_->keyframes().begin()->first};
  const std::map<int64_t, Rigid3d> before_graph = poses;
  OptimizePoseGraph(&poses, edges, fixed, options_.pose_graph_iterations);
  for (const auto& [id, k] : map_->keyframes()) {
    k->cam_from_world = poses[id];
    moved->push_back(id);
  }
  PointsFollowKeyFrames(*map_, before_graph, poses);
}

LoopCorrection LoopCorrector::Apply(const std::shared_ptr<KeyFrame>& kf, const LoopMatch& loop) {
  LoopCorrection result;
  std::lock_guard<std::mutex> lock(map_->mutex());
  // The checks ran without the lock: the map may have changed meanwhile. A culled keyframe or a
  // global correction (a global BA written back moves every pose the transform was computed
  // from) makes the loop stale: it is dropped (the revisit is seen again by later keyframes).
  if (kf->bad || loop.loop_kf->bad || map_->CorrectionEpoch() != loop.epoch) {
    LOG_INFO << "loop dropped: keyframe " << kf->id << " with keyframe " << loop.loop_kf->id
             << (kf->bad || loop.loop_kf->bad ? " (a keyframe was culled)"
                                              : " (the map was corrected during the checks)");
    return result;
  }
  result.applied = true;
  // A correction below the pose graph threshold moves nothing: the map was not lost, the
  // duplicated points are fused and the sides linked at the poses they have.
  result.fused_only = loop.correction_m < options_.pose_graph_min_correction_m &&
                      loop.correction_deg < options_.pose_graph_min_correction_deg;
  // Local BA in flight must not write back pre-loop poses (nothing moves when fusing only).
  if (!result.fused_only) map_->BumpCorrectionEpoch();
  // 1. Move the current keyframe's neighbourhood (and the points it sees) by the loop transform.
  const auto group = LoopGroup(kf, loop);
  std::map<int64_t, Rigid3d> uncorrected, corrected;
  const Rigid3d kf_from_world = kf->cam_from_world;
  for (const auto& g : group) {
    uncorrected[g->id] = g->cam_from_world;
    corrected[g->id] = (g->cam_from_world * kf_from_world.Inverse()) * loop.cam_from_world;
  }
  result.shift_m = (kf->CameraCenter() - loop.cam_from_world.Inverse().translation).norm();
  if (!result.fused_only) MoveGroup(*map_, group, uncorrected, corrected);
  // 2. Fuse duplicated points; 3. link the two sides.
  result.fused = FuseLoopPoints(kf, loop, group);
  const auto new_links = LinkAfterFusion(kf, loop, group);
  // The loop keyframes are not protected from culling (ORB-SLAM2 keeps every one for good, so a
  // robot returning to the same places grows its map by two keyframes per loop without bound).
  // A loop edge outlives its keyframes instead: it moves to the active keyframe that took over a
  // culled one's place (CompactLoopEdges), and repeated returns to the same pair of places leave
  // one edge. Fused only: kept for the pose graph of a later, larger loop, measured there from
  // the poses it sees.
  if (result.fused_only) {
    AddLoopEdges(new_links);
  } else {
    // 4. Essential graph; 5. points follow their reference keyframes.
    OptimizeEssentialGraph(loop, new_links, uncorrected, &result.moved);
    map_->BumpCorrectionEpoch();
  }
  result.loop_edges = loop_edges_.size();
  return result;
}

}  // namespace dygslam
