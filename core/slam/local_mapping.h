// Local mapping: for each new keyframe — cull recent map points, triangulate new points with
// covisible keyframes, fuse duplicates, local bundle adjustment, cull redundant keyframes.
// Runs in its own thread, or synchronously (deterministic mode) when the tracker calls
// ProcessPending().
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
#include "core/slam/map.h"
#include "core/slam/matcher.h"
#include "core/slam/optimizer.h"

namespace dygslam {

struct LocalMappingOptions {
  int triangulation_neighbors = 10;
  int fusion_neighbors = 10;
  int fusion_second_neighbors = 5;
  double fusion_radius_px = 3.0;
  double min_found_ratio = 0.25;
  double redundancy_ratio = 0.9;  // keyframe culled if this share of its points is seen >= 3 times elsewhere
  int redundancy_observations = 3;
  bool cull_keyframes = true;
  // At shutdown (System::Shutdown), a bundle adjustment of the whole map with this many
  // iterations per round (0: none); the trajectory follows its keyframes.
  int final_ba_iterations = 0;
  OptimizerOptions optimizer;
  MatcherOptions matcher;
  void Check() const {
    DYGSLAM_CHECK_OPTION(triangulation_neighbors >= 1, "LocalMapping.triangulation_neighbors");
    DYGSLAM_CHECK_OPTION(redundancy_ratio > 0 && redundancy_ratio <= 1, "LocalMapping.redundancy_ratio");
    DYGSLAM_CHECK_OPTION(redundancy_observations >= 1, "LocalMapping.redundancy_observations");
    DYGSLAM_CHECK_OPTION(fusion_neighbors >= 0 && fusion_second_neighbors >= 0, "LocalMapping.fusion_neighbors");
    DYGSLAM_CHECK_OPTION(fusion_radius_px > 0 && std::isfinite(fusion_radius_px), "LocalMapping.fusion_radius_px");
    DYGSLAM_CHECK_OPTION(min_found_ratio >= 0 && min_found_ratio <= 1, "LocalMapping.min_found_ratio");
    DYGSLAM_CHECK_OPTION(final_ba_iterations >= 0 && final_ba_iterations <= 1000,
                         "LocalMapping.final_ba_iterations");
    optimizer.Check();
    matcher.Check();
  }
};

struct LocalMappingStats {
  int keyframes_processed = 0;
  int points_triangulated = 0;
  int points_culled = 0;
  int keyframes_culled = 0;
  double total_ms = 0;
  std::vector<double> per_keyframe_ms;
  // The threaded schedule: keyframes whose fusion and local BA were skipped because
  // another keyframe was already queued, local BAs stopped early by a new keyframe, and per
  // keyframe the queue length found at insertion and the time from insertion to done.
  int keyframes_without_ba = 0;
  int ba_interrupted = 0;
  std::vector<int> queue_at_insert;
  std::vector<double> lag_ms;
};

class LocalMapper {
 public:
  LocalMapper(std::shared_ptr<Map> map, const LocalMappingOptions& options, bool threaded);
  ~LocalMapper();

  void InsertKeyFrame(std::shared_ptr<KeyFrame> kf);
  // Processes queued keyframes in the caller's thread (deterministic mode).
  void ProcessPending();
  bool Idle() const { return queue_.Idle(); }
  // Waits up to `timeout_ms` for Idle(); true when idle.
  bool WaitIdle(double timeout_ms) {
    return queue_.WaitIdle(std::chrono::duration<double, std::milli>(timeout_ms));
  }
  size_t QueueSize() const;
  void InterruptBA() { abort_ba_ = true; }
  // Waits until the queue is empty and the current keyframe is done, then stops the thread.
  void Finish();
  // Called (from the mapping thread) after each processed keyframe with the ids of keyframes whose
  // pose bundle adjustment changed and the ids of keyframes culled.
  using MapChangedCallback = std::function<void(const std::vector<int64_t>& moved, const std::vector<int64_t>& culled)>;
  void SetPosesChangedCallback(MapChangedCallback callback);
  // Called (from the mapping thread) with each keyframe once local mapping is done with it (loop
  // closing takes it from there).
  using KeyFrameDoneCallback = std::function<void(const std::shared_ptr<KeyFrame>&)>;
  void SetKeyFrameDoneCallback(KeyFrameDoneCallback callback);
  LocalMappingStats stats() const;

 private:
  void Process(const std::shared_ptr<KeyFrame>& kf);
  void CullRecentPoints(const std::shared_ptr<KeyFrame>& kf);
  void CreateNewMapPoints(const std::shared_ptr<KeyFrame>& kf);
  void FuseWithNeighbors(const std::shared_ptr<KeyFrame>& kf);
  void CullKeyFrames(const std::shared_ptr<KeyFrame>& kf);

  std::shared_ptr<Map> map_;
  LocalMappingOptions options_;
  Matcher matcher_;
  bool threaded_;
  mutable std::mutex callback_mutex_;
  std::atomic<bool> abort_ba_{false};
  std::list<std::shared_ptr<MapPoint>> recent_points_;  // local mapping thread only
  MapChangedCallback poses_changed_;
  KeyFrameDoneCallback keyframe_done_;
  std::vector<int64_t> culled_since_callback_;
  mutable std::mutex stats_mutex_;
  std::map<int64_t, std::chrono::steady_clock::time_point> inserted_at_;  // under stats_mutex_
  LocalMappingStats stats_;
  WorkQueue<std::shared_ptr<KeyFrame>> queue_;  // last: its worker uses everything above
};

}  // namespace dygslam
