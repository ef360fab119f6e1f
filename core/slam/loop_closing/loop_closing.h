// Loop closing, ORB-SLAM2's RGB-D order, on its own thread (synchronous in deterministic mode).
// One step per file:
//   1. detection (loop_detection.h): consistent loop candidates from the BoW index;
//   2. verification (loop_verification.h): an SE3 from matched map points, a guided search and a
//      pose refinement on a copy of the map state, without the map lock;
//   3. correction (loop_correction.h): the loop applied under the map lock, dropped if the map was
//      corrected meanwhile; duplicated points fused, the essential graph optimised;
//   4. a global bundle adjustment (global_bundle_adjustment.h) of every keyframe and point, in the
//      background (its own thread; synchronous in deterministic mode), written back only if no
//      newer loop came.
// Corrections are reported through the callback (ids of keyframes whose pose changed).
#pragma once

#include <atomic>
#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "core/base/work_queue.h"
#include "core/place/keyframe_database.h"
#include "core/slam/loop_closing/loop_closing_options.h"
#include "core/slam/loop_closing/loop_correction.h"
#include "core/slam/loop_closing/loop_detection.h"
#include "core/slam/loop_closing/loop_verification.h"
#include "core/slam/map/map.h"
#include "core/slam/feature/matcher.h"
#include "core/slam/optimize/optimizer.h"

namespace dygslam {

struct LoopClosingStats {
  int keyframes_checked = 0;
  int candidates_detected = 0;  // consistent candidates (before geometry)
  int loops_rejected = 0;       // keyframes whose candidates all failed the geometric checks
  // Candidates rejected, by check (first failed): too few BoW matches between map points, too
  // few inliers after refinement, inlier ratio, guided-search matches, correction larger than the
  // drift budget.
  int rejected_bow = 0;
  int rejected_inliers = 0, rejected_ratio = 0, rejected_projection = 0, rejected_implausible = 0;
  std::vector<LoopVerification> verifications;
  int loops_closed = 0;
  int points_fused = 0;
  // Loops accepted by the checks but not applied: the map was corrected (a global BA written
  // back) or a keyframe of the loop culled while the checks ran without the map lock.
  int loops_dropped = 0;
  // Wall time of the candidates' geometric checks, and the part of it spent holding the map lock
  // (copying what the checks need); matching, RANSAC and refinement run without it.
  double check_ms_total = 0, check_locked_ms_total = 0;
  double detect_ms_total = 0;  // candidate detection (index query), under the map lock
  int global_ba_runs = 0;
  int global_ba_discarded = 0;  // finished after a newer loop: not written back
  // Loops closed by fusion only (no keyframe moved, no pose graph): correction below
  // LoopClosing.pose_graph_min_correction_*.
  int pose_graph_skipped = 0;
  // Loop edges kept for later pose graphs after the last loop (between active keyframes, each
  // pair once): bounded by the places linked, not by the number of returns.
  int loop_edges = 0;
  double correction_ms_total = 0;
  double global_ba_ms_total = 0;  // wall time of the global BAs written back
  // Every global BA that got to its solver: [start, end] in seconds of std::chrono::steady_clock
  // (time_since_epoch), written back or not; and whether one is running now. For frame-time
  // studies while it runs (tracking must not wait for it).
  std::vector<std::pair<double, double>> global_ba_windows_s;
  bool global_ba_running = false;
  std::vector<std::pair<int64_t, int64_t>> loops;        // (keyframe id, loop keyframe id)
  std::vector<std::pair<int64_t, int64_t>> loop_frames;  // (frame id, loop keyframe's frame id)
};

// One line for run summaries: the candidates rejected by each geometric check and the strongest
// rejected one (most inliers), e.g. "loop rejections: 3 BoW matches, 2 inliers, ...; strongest:
// frame 587 vs frame 0: 35 / 60 inliers, 0 matches, correction ... (inliers)". Empty when no
// candidate was verified.
std::string LoopRejectionSummary(const LoopClosingStats& stats);

class LoopCloser {
 public:
  LoopCloser(std::shared_ptr<Map> map, std::shared_ptr<KeyFrameDatabase> database,
             const LoopClosingOptions& options, const OptimizerOptions& optimizer,
             const MatcherOptions& matcher, bool threaded, bool threaded_checks = true);
  ~LoopCloser();
  LoopCloser(const LoopCloser&) = delete;
  LoopCloser& operator=(const LoopCloser&) = delete;

  // A keyframe local mapping is done with. threaded_checks: queued for the loop thread; else
  // detected, verified and corrected here, in the caller's thread (the System's schedule: loop
  // corrections enter the map at a defined frame). `threaded`: the global BA on its own thread.
  void InsertKeyFrame(std::shared_ptr<KeyFrame> kf);
  // Waits for the queue and any global bundle adjustment, then stops the threads.
  void Finish();
  // Called after a correction (loop or global BA) with the keyframes whose pose changed.
  using CorrectionCallback = std::function<void(const std::vector<int64_t>& moved)>;
  void SetCorrectionCallback(CorrectionCallback callback);
  LoopClosingStats stats() const;
  // The loop edges kept for later pose graphs, between active keyframes (a culled keyframe's id
  // replaced by the active one that took its place), each pair once. Takes the map lock.
  std::vector<std::pair<int64_t, int64_t>> LoopEdges() const;

 private:
  void Process(const std::shared_ptr<KeyFrame>& kf);
  void StartGlobalBundleAdjustment(int64_t loop_kf_id);
  void RunGlobalBundleAdjustment(int64_t epoch);
  void Report(const std::vector<int64_t>& moved);

  std::shared_ptr<Map> map_;
  LoopClosingOptions options_;
  OptimizerOptions optimizer_;
  bool threaded_;
  LoopDetector detector_;    // loop thread only
  LoopVerifier verifier_;    // stateless
  LoopCorrector corrector_;  // loop thread only (LoopEdges() from any)

  mutable std::mutex callback_mutex_;
  CorrectionCallback callback_;
  mutable std::mutex stats_mutex_;
  LoopClosingStats stats_;
  std::mutex global_ba_mutex_;
  std::thread global_ba_thread_;
  std::atomic<bool> global_ba_abort_{false};
  WorkQueue<std::shared_ptr<KeyFrame>> queue_;  // last: its worker uses everything above
};

}  // namespace dygslam
