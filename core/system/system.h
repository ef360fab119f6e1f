// The SLAM system as a library: RGB-D frames in, poses / keyframes out. No middleware.
//   System system(options);
//   FrameResult r = system.FeedRgbdFrame(rgb, depth, stamp);              // runs its own detector
//   FrameResult r = system.FeedRgbdFrame(rgb, depth, stamp, mask, &dets); // detections from outside
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/base/camera.h"
#include "core/base/types.h"

namespace dygslam {

enum class FilterMode { kNone, kBoxes, kGeometry, kFull };
const char* ToString(FilterMode mode);
// "none" | "boxes" | "geometry" | "full"; throws InvalidOptions otherwise.
FilterMode ParseFilterMode(const std::string& text);

// Per-frame stage times in milliseconds (the paper's Table 3 columns).
struct StageTimes {
  double orb_extraction_ms = 0;
  double detection_ms = 0;        // detector wall time (may overlap extraction)
  double detection_wait_ms = 0;   // time tracking waited for the detector after extraction
  double matching_ms = 0;         // dynamic filter: feature matching to previous frame
  double probability_ms = 0;      // dynamic filter: F estimation + probability update
  double tracking_ms = 0;         // pose tracking (motion model / reference KF / local map)
  double total_ms = 0;            // wall time of FeedRgbdFrame
};

struct FrameResult {
  Timestamp stamp;
  TrackingState state = TrackingState::kNotInitialized;
  std::optional<Rigid3d> world_from_cam;  // set only when HasPose(state)
  bool is_keyframe = false;
  int num_features = 0;
  int num_dynamic = 0;      // features removed by the dynamic filter
  int num_tracked = 0;      // inlier map-point matches after pose optimisation
  bool detections_used = false;
  StageTimes times;
};

}  // namespace dygslam
