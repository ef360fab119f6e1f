// Plain data types shared by the libraries and the DDS shells (no behaviour, no middleware).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/base/rigid3.h"
#include "core/base/timestamp.h"

namespace dygslam {

enum class TrackingState : uint8_t {
  kNotInitialized = 0,  // no map yet (first frame without enough depth)
  kOk = 1,              // tracked; pose valid
  kRelocalized = 2,     // pose recovered by relocalization on this frame; pose valid
  kLost = 3,            // not tracked; no pose is reported
  kFallback = 4,        // features failed; pose from the verified dense fallback (no keyframe)
};
const char* ToString(TrackingState state);
inline bool HasPose(TrackingState s) {
  return s == TrackingState::kOk || s == TrackingState::kRelocalized ||
         s == TrackingState::kFallback;
}

// One detected object in image coordinates (pixels, top-left origin).
struct Detection {
  cv::Rect2f box;
  int class_id = 0;
  std::string label;
  float score = 0.f;
};

struct StampedPose {
  Timestamp stamp;
  Rigid3d world_from_cam;
};

// What the SLAM emits for each new keyframe (and again when its pose is corrected): everything the
// map needs to insert the static part of the keyframe.
struct KeyframeData {
  int64_t id = -1;
  Timestamp stamp;
  Rigid3d world_from_cam;
  cv::Mat rgb;           // CV_8UC3 BGR
  cv::Mat depth;         // CV_32FC1 metres, 0 = no measurement
  cv::Mat dynamic_mask;  // CV_8UC1, 255 = pixel judged dynamic (boxes refined by depth, dynamic features)
  std::vector<cv::KeyPoint> keypoints;
  std::vector<uint8_t> keypoint_dynamic;  // 1 = feature judged dynamic (removed before tracking)
  std::vector<Detection> detections;
  bool pose_update_only = false;  // true: only world_from_cam changed since last emission
  bool removed = false;           // true: the keyframe was culled; drop it from the map
};

}  // namespace dygslam
