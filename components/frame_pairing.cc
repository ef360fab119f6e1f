#include "components/frame_pairing.h"

#include <algorithm>

#include "core/base/error.h"
#include "core/base/log.h"

namespace dygslam {

void PairingOptions::Check() const {
  DYGSLAM_CHECK_OPTION(max_wait.count() >= 0, "slam.detection_wait_ms");
  DYGSLAM_CHECK_OPTION(lost_after_misses >= 1, "slam.detector_lost_after_misses");
  DYGSLAM_CHECK_OPTION(carry_forward_max_frames >= 0, "slam.carry_forward_max_frames");
  DYGSLAM_CHECK_OPTION(carry_forward_max_age.count() >= 0, "slam.carry_forward_max_age_ms");
  DYGSLAM_CHECK_OPTION(detection_every_n_frames >= 1 && detection_every_n_frames <= 1000,
                       "Detector.every_n_frames (1..1000)");
}

bool FramePairer::ExpectsDetections(const RgbdFrameData& frame) const {
  return options_.needs_detections &&
         frame.seq % static_cast<uint64_t>(options_.detection_every_n_frames) == 0;
}

FramePairer::FramePairer(const PairingOptions& options) : options_(options) { options_.Check(); }

void FramePairer::AddFrame(RgbdFrameData frame, Clock::time_point now) {
  frames_.push_back({std::move(frame), now});
  DropFramesOverTheBound();
}

bool FramePairer::WaitsForDetections(const Pending& pending) const {
  return ExpectsDetections(pending.frame) && !detector_lost_ &&
         detections_.count(pending.frame.stamp.nanoseconds()) == 0;
}

void FramePairer::DropFramesOverTheBound() {
  // A front frame that waits for its detections holds the frames behind it: that wait has its own
  // bound (max_wait, then the detector counts as lost), so the frames are not dropped for it.
  while (options_.max_pending_frames > 0 && frames_.size() > options_.max_pending_frames &&
         !WaitsForDetections(frames_.front())) {
    if (stats_.dropped_frames == 0) {
      LOG_WARNING << "slam: frames arrive faster than they are tracked; the oldest waiting "
                     "frame is dropped when more than "
                  << options_.max_pending_frames << " wait (counted)";
    }
    // As if released: its detections, when they come, are late (the boxes carried forward).
    last_released_stamp_ =
        std::max(last_released_stamp_, frames_.front().frame.stamp.nanoseconds());
    detections_.erase(detections_.begin(), detections_.upper_bound(last_released_stamp_));
    frames_.pop_front();
    ++stats_.dropped_frames;
  }
}

void FramePairer::AddDetections(Timestamp stamp, std::vector<Detection> detections) {
  if (detector_lost_ && detector_alive_) {
    LOG_INFO << "slam: detections are arriving again; waiting for them again";
    detector_lost_ = false;
    gone_unreported_ = false;
    consecutive_misses_ = 0;
  }
  const int64_t ns = stamp.nanoseconds();
  if (ns <= last_released_stamp_) {
    ++stats_.dropped_detections;
    // Too late for its own frame; still the newest view of where the people are.
    if (!newest_ || newest_->first < ns) {
      newest_.emplace(ns, std::move(detections));
      ++stats_.late_used;
    }
    return;
  }
  if (!newest_ || newest_->first < ns) newest_.emplace(ns, detections);
  detections_[ns] = std::move(detections);
}

void FramePairer::SetDetectorAlive(bool alive) {
  if (!alive && detector_alive_ && options_.needs_detections) {
    gone_unreported_ = !detector_lost_;  // already lost by misses: that was reported
    detector_lost_ = true;
  }
  detector_alive_ = alive;
}

std::optional<FramePairer::Clock::time_point> FramePairer::NextDeadline() const {
  if (frames_.empty()) return std::nullopt;
  if (!ExpectsDetections(frames_.front().frame) || detector_lost_) return frames_.front().arrival;
  if (options_.deterministic) return std::nullopt;
  return frames_.front().arrival + options_.max_wait;
}

std::optional<PairedFrame> FramePairer::Next(Clock::time_point now) {
  DropFramesOverTheBound();  // frames that waited behind a front frame's detections
  if (frames_.empty()) return std::nullopt;
  Pending& front = frames_.front();
  const int64_t stamp = front.frame.stamp.nanoseconds();
  PairedFrame out;
  auto it = detections_.find(stamp);
  if (!options_.needs_detections) {
    // Release as is.
  } else if (!ExpectsDetections(front.frame)) {
    out.detector_skipped = true;  // the System carries the last detector frame's boxes to it
    ++stats_.skipped_by_cadence;
  } else if (it != detections_.end()) {
    out.detections = std::move(it->second);
    ++stats_.with_detections;
    consecutive_misses_ = 0;
    consecutive_carried_ = 0;
  } else {
    const bool waited_enough =
        detector_lost_ || (!options_.deterministic && now >= front.arrival + options_.max_wait);
    if (!waited_enough) return std::nullopt;
    out.detections_missing = true;
    ++stats_.missing_detections;
    if (gone_unreported_) {
      LOG_WARNING << "slam: the detector is gone; continuing with its last boxes carried forward "
                     "(at most "
                  << options_.carry_forward_max_frames << " frames), then geometry-only";
      ++stats_.lost_episodes;
      gone_unreported_ = false;
    }
    const bool recent =
        newest_ && newest_->first < stamp &&
        stamp - newest_->first <=
            std::chrono::duration_cast<std::chrono::nanoseconds>(options_.carry_forward_max_age)
                .count();
    if (recent && consecutive_carried_ < options_.carry_forward_max_frames) {
      out.detections = newest_->second;
      out.detections_carried_forward = true;
      out.carried_from = Timestamp::FromNanoseconds(newest_->first);
      ++consecutive_carried_;
      ++stats_.carried_forward;
    }
    if (!detector_lost_ && ++consecutive_misses_ >= options_.lost_after_misses) {
      LOG_WARNING << "slam: no detections for " << consecutive_misses_
                  << " frames in a row; no more waiting for them (boxes carried forward, at "
                     "most "
                  << options_.carry_forward_max_frames << " frames, then geometry-only)";
      detector_lost_ = true;
      ++stats_.lost_episodes;
    }
  }
  out.frame = std::move(front.frame);
  frames_.pop_front();
  last_released_stamp_ = stamp;
  // Forget detections of frames already released.
  detections_.erase(detections_.begin(), detections_.upper_bound(stamp));
  ++stats_.frames;
  return out;
}

}  // namespace dygslam
