// Local mapping: for each new keyframe — cull recent map points, triangulate new points with
// covisible keyframes, fuse duplicates, local bundle adjustment, cull redundant keyframes.
//
// The schedule (docs/ARCHITECTURE.md, "Tracking and local mapping"): the map changes only at
// defined points of the frame sequence, so a threaded run gives the same trajectory every time.
// - A keyframe made on frame k is inserted by tracking: its recent points are culled, new points
//   triangulated and duplicates fused right then (in tracking's thread), and the local bundle
//   adjustment is copied in.
// - The local BA is solved on the mapping thread while tracking goes on with frames k+1, k+2, ...
//   on the map as it was.
// - Before frame k + ba_lag_frames is tracked (or before the next keyframe is inserted, if that
//   comes first) its result is written back and redundant keyframes are culled. A solve that is
//   not done by then is waited for (counted: LocalMappingStats::late_bundle_adjustments): the
//   trajectory stays the same, only that frame comes later.
// Unthreaded (deterministic mode), the solve runs in the caller's thread at the same point: the
// output is identical.
#pragma once

#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <functional>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <thread>

#include "core/base/work_queue.h"
#include "core/slam/map/map.h"
#include "core/slam/feature/matcher.h"
#include "core/slam/optimize/optimizer.h"

namespace dygslam {

struct LocalMappingOptions {
  int triangulation_neighbors = 10;
  int fusion_neighbors = 10;
  int fusion_second_neighbors = 5;
  double fusion_radius_px = 3.0;
  double min_found_ratio = 0.25;
  double redundancy_ratio =
      0.9;  // keyframe culled if this share of its points is seen >= 3 times elsewhere
  int redundancy_observations = 3;
  bool cull_keyframes = true;
  // Frames tracked on the map as it was while a keyframe's local BA is solved: its result lands
  // before frame k + ba_lag_frames (k: the keyframe's frame). 0: at once, in tracking's thread.
  int ba_lag_frames = 2;
  OptimizerOptions optimizer;
  MatcherOptions matcher;
  void Check() const {
    DYGSLAM_CHECK_OPTION(triangulation_neighbors >= 1, "LocalMapping.triangulation_neighbors");
    DYGSLAM_CHECK_OPTION(redundancy_ratio > 0 && redundancy_ratio <= 1,
                         "LocalMapping.redundancy_ratio");
    DYGSLAM_CHECK_OPTION(redundancy_observations >= 1, "LocalMapping.redundancy_observations");
    DYGSLAM_CHECK_OPTION(fusion_neighbors >= 0 && fusion_second_neighbors >= 0,
                         "LocalMapping.fusion_neighbors");
    DYGSLAM_CHECK_OPTION(fusion_radius_px > 0 && std::isfinite(fusion_radius_px),
                         "LocalMapping.fusion_radius_px");
    DYGSLAM_CHECK_OPTION(min_found_ratio >= 0 && min_found_ratio <= 1,
                         "LocalMapping.min_found_ratio");
    DYGSLAM_CHECK_OPTION(ba_lag_frames >= 0 && ba_lag_frames <= 30, "LocalMapping.ba_lag_frames");
    optimizer.Check();
    matcher.Check();
  }
};

struct LocalMappingStats {
  int keyframes_processed = 0;
  int points_triangulated = 0;
  int points_culled = 0;
  int keyframes_culled = 0;
  double total_ms = 0;  // in tracking's thread and on the mapping thread
  std::vector<double> per_keyframe_ms;
  std::vector<double> insert_ms;     // per keyframe: the part in tracking's thread
  std::vector<double> solve_ms;      // per keyframe: the local BA's solve (mapping thread)
  std::vector<int> ba_keyframes;     // per keyframe: keyframes the local BA optimised
  std::vector<int> ba_observations;  // per keyframe: observations in the local BA
  // Local BAs whose solve was not done when their result was due: tracking waited for them.
  int late_bundle_adjustments = 0;
  double late_wait_ms = 0;  // time tracking waited for them, in all
  // Local BAs landed early because the next keyframe came before ba_lag_frames frames.
  int early_landings = 0;
};

class LocalMapper {
 public:
  LocalMapper(std::shared_ptr<Map> map, const LocalMappingOptions& options, bool threaded);
  ~LocalMapper();

  // A new keyframe, made on frame `kf->frame_id`, from tracking's thread (map lock not held):
  // lands a pending local BA first, then culls recent points, triangulates, fuses and starts the
  // keyframe's local BA.
  void InsertKeyFrame(std::shared_ptr<KeyFrame> kf);
  // Called by tracking before each frame (map lock not held): lands the pending local BA when
  // frame `frame_id` is the one it is due before.
  void BeginFrame(int64_t frame_id);
  // No local BA pending.
  bool Idle() const { return !pending_; }
  // Lands a pending local BA and stops the mapping thread.
  void Finish();
  // Called (tracking's thread) after each landed keyframe with the ids of keyframes whose pose
  // bundle adjustment changed and the ids of keyframes culled.
  using MapChangedCallback =
      std::function<void(const std::vector<int64_t>& moved, const std::vector<int64_t>& culled)>;
  void SetPosesChangedCallback(MapChangedCallback callback);
  // Called (tracking's thread) with each keyframe once local mapping is done with it (loop
  // closing takes it from there).
  using KeyFrameDoneCallback = std::function<void(const std::shared_ptr<KeyFrame>&)>;
  void SetKeyFrameDoneCallback(KeyFrameDoneCallback callback);
  LocalMappingStats stats() const;

 private:
  struct Job {
    std::shared_ptr<KeyFrame> kf;
    BundleProblem bundle;
    std::vector<int64_t> window;  // keyframes whose pose the BA may change
    int64_t due_frame = 0;
    double insert_ms = 0;
    double solve_ms = 0;
  };
  void Land();
  void CullRecentPoints(const std::shared_ptr<KeyFrame>& kf);
  void CreateNewMapPoints(const std::shared_ptr<KeyFrame>& kf);
  void FuseWithNeighbors(const std::shared_ptr<KeyFrame>& kf);
  void CullKeyFrames(const std::shared_ptr<KeyFrame>& kf, std::vector<int64_t>* culled);
  static void Solve(Job& job, const OptimizerOptions& options);

  std::shared_ptr<Map> map_;
  LocalMappingOptions options_;
  Matcher matcher_;
  bool threaded_;
  mutable std::mutex callback_mutex_;
  MapChangedCallback poses_changed_;
  KeyFrameDoneCallback keyframe_done_;
  std::list<std::shared_ptr<MapPoint>> recent_points_;  // tracking's thread only
  std::shared_ptr<Job> pending_;                        // tracking's thread only
  mutable std::mutex stats_mutex_;
  LocalMappingStats stats_;
  WorkQueue<std::shared_ptr<Job>> solver_;  // last: its worker uses everything above
};

}  // namespace dygslam
