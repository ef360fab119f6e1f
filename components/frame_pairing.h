// Pairs each RGB-D frame with the detections computed from it (matched by stamp), with the
// waiting policy of the slam component. No DDS, no threads: the caller feeds frames, detections
// and the current time and asks for the next frame that is ready.
//
// Policy:
// - deterministic: a frame waits for its detections without limit, unless the detector is known
//   to be gone (SetDetectorAlive(false)): then frames proceed without detections.
// - normal: a frame waits at most `max_wait` after it arrived; then it proceeds without its own
//   detections (counted). After `lost_after_misses` consecutive misses the detector is considered
//   lost: frames no longer wait at all until detections arrive again.
// - a frame that goes on without its own detections gets the newest detections received so far
//   (of an earlier frame: "carried forward", at most `carry_forward_max_frames` frames in a row
//   and at most `carry_forward_max_age` older than the frame), so the dynamic filter still
//   removes the people's features (and propagates its per-feature probabilities) instead of
//   running unfiltered. Detections that arrive after their frame was released are not used for
//   that frame (it is gone) but become the boxes carried forward to the next frames (counted as
//   late). Without any recent detections the frame goes on geometry-only.
// - detections not needed (filter mode none / geometry, or internal detector): no waiting.
// - detector cadence (`Detector.every_n_frames` = n > 1): the detector component runs
//   on the frames whose seq is a multiple of n only; the others are released at once, without
//   waiting and without counting a miss (PairedFrame::detector_skipped): the System carries the
//   boxes of the last detector frame to them. Deterministic mode stays deterministic: which
//   frames get no detections follows from seq alone.
// - at most `max_pending_frames` frames wait: a newer frame that arrives when that many wait
//   pushes the oldest out (counted as dropped; its detections, if they come, are late). A camera
//   does not wait for the pipeline: a slam slower than the camera drops frames, as a camera
//   driver's bounded queue does, instead of falling further behind (latency growing without
//   bound). A player with a back-pressure window (fewer frames in flight than this bound) is
//   never cut. The frames behind an oldest frame that waits for its detections are kept while it
//   waits (that wait is bounded by max_wait and the detector-lost rule); the excess goes when it
//   has been released.
#pragma once

#include <chrono>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <vector>

#include "components/convert.h"
#include "core/base/types.h"

namespace dygslam {

struct PairingOptions {
  bool needs_detections = true;
  bool deterministic = false;
  // Long enough that a detector keeping up is always waited for (its frames are paired the same
  // way every run: a reproducible trajectory); a detector a second behind counts as stalled.
  std::chrono::milliseconds max_wait{1000};
  int lost_after_misses = 5;
  int carry_forward_max_frames = 30;                      // 0: never carry boxes forward
  std::chrono::milliseconds carry_forward_max_age{1000};  // stamp difference, frame to boxes
  // The detector runs on the frames with seq % detection_every_n_frames == 0 only.
  int detection_every_n_frames = 1;
  // Frames waiting at most; the oldest is dropped when a newer one would exceed it (0: no bound;
  // the slam component holds as many as the frame topic's history).
  size_t max_pending_frames = 0;
  void Check() const;
};

struct PairedFrame {
  RgbdFrameData frame;
  // Set when the frame's detections arrived in time.
  std::optional<std::vector<Detection>> detections;
  bool detections_missing = false;  // needed but not available (frame goes on without them)
  // detections_missing and `detections` holds an earlier frame's boxes (carried forward).
  bool detections_carried_forward = false;
  Timestamp carried_from;  // stamp of the frame those boxes were detected on
  // The detector does not run on this frame (cadence): no detections, none missing.
  bool detector_skipped = false;
};

// Counts the frames filtered without any person boxes although the run asked for them: a frame
// due its own boxes that got none (not even carried ones), and a frame the cadence skips after
// such a frame (it carries what the last detector frame had: nothing). A frame skipped after a
// frame with boxes carries them.
class BoxCoverage {
 public:
  void Add(const PairedFrame& paired) {
    if (!paired.detector_skipped)
      last_without_boxes_ = paired.detections_missing && !paired.detections_carried_forward;
    if (last_without_boxes_) ++frames_without_boxes_;
  }
  size_t frames_without_boxes() const { return frames_without_boxes_; }

 private:
  bool last_without_boxes_ = false;
  size_t frames_without_boxes_ = 0;
};

struct PairingStats {
  size_t frames = 0;
  size_t with_detections = 0;
  size_t missing_detections = 0;  // frames that went on without detections
  size_t dropped_detections = 0;  // detections whose frame was already processed (late)
  size_t carried_forward = 0;     // frames that got an earlier frame's detections
  size_t late_used = 0;           // late detections that became the boxes carried forward
  size_t lost_episodes = 0;       // times the detector was declared lost
  size_t skipped_by_cadence = 0;  // frames the detector does not run on (every_n_frames)
  size_t dropped_frames = 0;      // pushed out by newer frames (max_pending_frames)
};

class FramePairer {
 public:
  using Clock = std::chrono::steady_clock;
  explicit FramePairer(const PairingOptions& options);

  void AddFrame(RgbdFrameData frame, Clock::time_point now);
  void AddDetections(Timestamp stamp, std::vector<Detection> detections);
  // The detector's writer disappeared (false) or (re)appeared (true).
  void SetDetectorAlive(bool alive);

  // The oldest frame if it is ready under the policy at `now`; frames come out in arrival order.
  std::optional<PairedFrame> Next(Clock::time_point now);
  // When the oldest pending frame will be ready at the latest (nullopt: no frame pending, or it
  // waits without limit).
  std::optional<Clock::time_point> NextDeadline() const;

  size_t pending_frames() const { return frames_.size(); }
  bool detector_lost() const { return detector_lost_; }
  const PairingStats& stats() const { return stats_; }

 private:
  struct Pending {
    RgbdFrameData frame;
    Clock::time_point arrival;
  };
  // Detections are expected for this frame (filter needs them and the cadence runs the detector).
  bool ExpectsDetections(const RgbdFrameData& frame) const;
  // The frame would wait for its detections now (expected, not there, detector not lost).
  bool WaitsForDetections(const Pending& pending) const;
  // max_pending_frames: the oldest frames go (counted) while more wait, unless the oldest waits
  // for its detections.
  void DropFramesOverTheBound();
  PairingOptions options_;
  std::deque<Pending> frames_;
  std::map<int64_t, std::vector<Detection>> detections_;  // by stamp (ns)
  int64_t last_released_stamp_ = INT64_MIN;
  bool detector_alive_ = true;
  bool detector_lost_ = false;
  // The detector went away (SetDetectorAlive(false)) and no frame has lacked its boxes since: the
  // warning and the lost episode wait for the first frame that does (a detector that finished its
  // stream just before its status said so is not a loss).
  bool gone_unreported_ = false;
  int consecutive_misses_ = 0;
  int consecutive_carried_ = 0;
  // The newest detections received (by frame stamp), what a frame without its own gets.
  std::optional<std::pair<int64_t, std::vector<Detection>>> newest_;
  PairingStats stats_;
};

}  // namespace dygslam
