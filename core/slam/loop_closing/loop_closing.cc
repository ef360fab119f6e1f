#include "core/slam/loop_closing/loop_closing.h"

#include <chrono>
#include <cstdio>
#include <string>

#include "core/base/log.h"
#include "core/base/memory.h"
#include "core/base/thread_setup.h"
#include "core/slam/loop_closing/global_bundle_adjustment.h"

namespace dygslam {

std::string LoopRejectionSummary(const LoopClosingStats& stats) {
  const LoopVerification* strongest = nullptr;
  for (const LoopVerification& v : stats.verifications) {
    if (std::string(v.verdict) == "accepted") continue;
    if (!strongest || v.inliers > strongest->inliers ||
        (v.inliers == strongest->inliers && v.bow_pairs > strongest->bow_pairs))
      strongest = &v;
  }
  if (!strongest) return "";
  char line[512];
  std::snprintf(
      line, sizeof(line),
      "loop rejections: %d BoW matches, %d inliers, %d inlier ratio, %d guided matches, "
      "%d implausible correction; strongest: frame %lld vs frame %lld: %d / %d inliers, "
      "%d matches, correction %.3f m / %.2f deg (budget %.3f m / %.2f deg over %.2f m): "
      "%s",
      stats.rejected_bow, stats.rejected_inliers, stats.rejected_ratio, stats.rejected_projection,
      stats.rejected_implausible, static_cast<long long>(strongest->frame_id),
      static_cast<long long>(strongest->loop_frame_id), strongest->inliers, strongest->bow_pairs,
      strongest->projected, strongest->correction_m, strongest->correction_deg,
      strongest->allowed_m, strongest->allowed_deg, strongest->path_m, strongest->verdict);
  return line;
}

LoopCloser::LoopCloser(std::shared_ptr<Map> map, std::shared_ptr<KeyFrameDatabase> database,
                       const LoopClosingOptions& options, const OptimizerOptions& optimizer,
                       const MatcherOptions& matcher, bool threaded, bool threaded_checks)
    : map_(map),
      options_(options),
      optimizer_(optimizer),
      threaded_(threaded),
      detector_(map, std::move(database), options),
      verifier_(map, options, optimizer, matcher),
      corrector_(map, options, matcher),
      queue_([this](std::shared_ptr<KeyFrame>& kf) { Process(kf); }, threaded && threaded_checks,
             /*capacity=*/0, "loop closing") {
  options_.Check();
}

LoopCloser::~LoopCloser() { Finish(); }

void LoopCloser::SetCorrectionCallback(CorrectionCallback callback) {
  std::lock_guard<std::mutex> lock(callback_mutex_);
  callback_ = std::move(callback);
}

LoopClosingStats LoopCloser::stats() const {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  return stats_;
}

void LoopCloser::InsertKeyFrame(std::shared_ptr<KeyFrame> kf) {
  queue_.Push(std::move(kf));
  queue_.Drain();  // unthreaded: processed now
}

void LoopCloser::Finish() {
  queue_.Finish();
  std::lock_guard<std::mutex> lock(global_ba_mutex_);
  if (global_ba_thread_.joinable()) global_ba_thread_.join();
}

void LoopCloser::Report(const std::vector<int64_t>& moved) {
  CorrectionCallback callback;
  {
    std::lock_guard<std::mutex> lock(callback_mutex_);
    callback = callback_;
  }
  if (callback && !moved.empty()) callback(moved);
}

void LoopCloser::Process(const std::shared_ptr<KeyFrame>& kf) {
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    stats_.keyframes_checked++;
  }
  if (!options_.enabled) return;
  const auto detect_start = std::chrono::steady_clock::now();
  const auto candidates = detector_.Detect(kf);
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    stats_.detect_ms_total +=
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - detect_start)
            .count();
  }
  if (candidates.empty()) return;
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    stats_.candidates_detected += static_cast<int>(candidates.size());
  }
  const auto check_start = std::chrono::steady_clock::now();
  LoopCheckRecord record;
  const std::optional<LoopMatch> loop = verifier_.Verify(kf, candidates, &record);
  const bool found = loop.has_value();
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    stats_.check_ms_total +=
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - check_start)
            .count();
    stats_.check_locked_ms_total += record.locked_ms;
    stats_.rejected_bow += record.rejected_bow;
    stats_.rejected_inliers += record.rejected_inliers;
    stats_.rejected_ratio += record.rejected_ratio;
    stats_.rejected_projection += record.rejected_projection;
    stats_.rejected_implausible += record.rejected_implausible;
    stats_.verifications.insert(stats_.verifications.end(), record.verifications.begin(),
                                record.verifications.end());
    if (!found) stats_.loops_rejected++;
  }
  if (!found) return;
  const auto start = std::chrono::steady_clock::now();
  const LoopCorrection correction = corrector_.Apply(kf, *loop);
  if (correction.applied) detector_.LoopClosedAt(kf->id);
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    if (correction.applied) {
      stats_.loop_edges = static_cast<int>(correction.loop_edges);
      stats_.loops_closed++;
      stats_.points_fused += correction.fused;
      if (correction.fused_only) stats_.pose_graph_skipped++;
      stats_.loops.push_back({kf->id, loop->loop_kf->id});
      stats_.loop_frames.push_back({kf->frame_id, loop->loop_kf->frame_id});
    } else {
      stats_.loops_dropped++;
    }
    stats_.correction_ms_total += ms;
  }
  if (correction.applied) {
    LOG_INFO << "loop closed: keyframe " << kf->id << " (frame " << kf->frame_id
             << ") with keyframe " << loop->loop_kf->id << " (frame " << loop->loop_kf->frame_id
             << "): " << loop->inliers << " RANSAC inliers, " << loop->projected
             << " matches, correction " << correction.shift_m << " m, " << correction.fused
             << " points fused"
             << (correction.fused_only
                     ? " (below LoopClosing.pose_graph_min_correction_m / _deg: no keyframe "
                       "moved, no pose graph)"
                     : "");
    Report(correction.moved);
  }
  // Nothing moved when the loop was only fused: nothing for a global BA to spread.
  if (!correction.applied || correction.fused_only || !options_.global_bundle_adjustment) return;
  StartGlobalBundleAdjustment(kf->id);
}

std::vector<std::pair<int64_t, int64_t>> LoopCloser::LoopEdges() const {
  return corrector_.LoopEdges();
}

// A global BA allocates the whole map's problem at once (tens of MB, in its thread's malloc arena)
// and frees it at the end: ReleaseFreedMemory hands the pages back (the 30-minute soak saw RSS step
// up 18 MB around its one global BA while the heap in use stayed flat).
void LoopCloser::StartGlobalBundleAdjustment(int64_t loop_kf_id) {
  const int64_t epoch = map_->CorrectionEpoch();
  std::lock_guard<std::mutex> lock(global_ba_mutex_);
  if (global_ba_thread_.joinable()) {
    global_ba_abort_ = true;
    global_ba_thread_.join();
  }
  global_ba_abort_ = false;
  if (!threaded_) {
    RunGlobalBundleAdjustment(epoch);
    ReleaseFreedMemory();
    return;
  }
  global_ba_thread_ = std::thread([this, epoch] {
    SetCurrentThreadName("global BA");
    RunGlobalBundleAdjustment(epoch);
    ReleaseFreedMemory();
  });
}

void LoopCloser::RunGlobalBundleAdjustment(int64_t epoch) {
  using Outcome = GlobalBundleAdjustmentResult::Outcome;
  auto steady_s = [](std::chrono::steady_clock::time_point t) {
    return std::chrono::duration<double>(t.time_since_epoch()).count();
  };
  std::chrono::steady_clock::time_point start;
  const GlobalBundleAdjustmentResult result = dygslam::RunGlobalBundleAdjustment(
      *map_, epoch, optimizer_, options_.global_ba_iterations, global_ba_abort_,
      [&](std::chrono::steady_clock::time_point started) {
        start = started;
        std::lock_guard<std::mutex> lock(stats_mutex_);
        stats_.global_ba_running = true;
        stats_.global_ba_windows_s.push_back({steady_s(start), steady_s(start)});
      });
  if (result.outcome == Outcome::kNotRun) return;
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    stats_.global_ba_running = false;
    stats_.global_ba_windows_s.back().second = steady_s(std::chrono::steady_clock::now());
    if (result.outcome == Outcome::kDiscarded) {
      stats_.global_ba_discarded++;
      return;
    }
    stats_.global_ba_runs++;
    stats_.global_ba_ms_total += ms;
  }
  LOG_INFO << "global BA: " << result.keyframes << " keyframes, " << result.points << " points, "
           << result.observations << " observations, " << ms << " ms (wall, its own thread)";
  Report(result.moved);
}

}  // namespace dygslam
