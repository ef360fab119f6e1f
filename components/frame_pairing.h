// Pairs each RGB-D frame with the detections computed from it (matched by stamp), with the
// waiting policy of the slam component. No DDS, no threads: the caller feeds frames, detections
// and the current time and asks for the next frame that is ready.
//
// Policy:
// - deterministic: a frame waits for its detections without limit, unless the detector is known
//   to be gone (SetDetectorAlive(false)): then frames proceed without detections.
// - normal: a frame waits at most `max_wait` after it arrived; then it proceeds without
//   detections (counted). After `lost_after_misses` consecutive misses the detector is considered
//   lost: frames no longer wait at all (geometry-only) until detections arrive again.
// - detections not needed (filter mode none / geometry, or internal detector): no waiting.
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
  std::chrono::milliseconds max_wait{150};
  int lost_after_misses = 5;
  void Check() const;
};

struct PairedFrame {
  RgbdFrameData frame;
  // Set when the frame's detections arrived in time.
  std::optional<std::vector<Detection>> detections;
  bool detections_missing = false;  // needed but not available (frame goes on without them)
};

struct PairingStats {
  size_t frames = 0;
  size_t with_detections = 0;
  size_t missing_detections = 0;  // frames that went on without detections
  size_t dropped_detections = 0;  // detections whose frame was already processed
  size_t lost_episodes = 0;       // times the detector was declared lost
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
  PairingOptions options_;
  std::deque<Pending> frames_;
  std::map<int64_t, std::vector<Detection>> detections_;  // by stamp (ns)
  int64_t last_released_stamp_ = INT64_MIN;
  bool detector_alive_ = true;
  bool detector_lost_ = false;
  int consecutive_misses_ = 0;
  PairingStats stats_;
};

}  // namespace dygslam
