// Detection boxes carried between detector runs (`Detector.every_n_frames` > 1): the detector runs
// on every k-th frame only; the frames in between reuse the newest boxes, each shifted by the image
// motion of its content, estimated from the feature matches the dynamic filter already made
// (frame t-1 -> t, FeatureStatus::prev_match): constant velocity per box over the gap. The
// per-feature probabilities need no extra step: the filter's Kalman state travels through the
// matches whether the boxes were detected or carried (its prediction and update run every frame).
//
//   BoxPropagator boxes(options);
//   if (detected) boxes.SetDetections(detections);      // a detector frame
//   std::vector<Detection> carried = boxes.Predict();   // a frame in between
//   ... filter.Process(...) ...
//   boxes.Observe(prev_keypoints, keypoints, result);    // after the filter, every frame
//
// No threads, no DDS.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "core/base/error.h"
#include "core/base/types.h"
#include "core/dynamic/dynamic_filter.h"

namespace dygslam {

struct BoxPropagationOptions {
  // Matched features inside a box needed to estimate its motion; fewer: the box keeps its
  // last velocity (zero at first).
  int min_matches = 4;
  // false: boxes are carried unchanged (the DDS pipeline's carry-forward).
  bool shift_boxes = true;
  void Check() const { DYGSLAM_CHECK_OPTION(min_matches >= 1, "box_propagation.min_matches"); }
};

// Median displacement (px, previous -> current) of the matched features whose current position
// lies in `box`;
// `count` gets the number of such matches. Zero when there is none.
cv::Point2f MedianDisplacementInBox(const cv::Rect2f& box,
                                    const std::vector<cv::KeyPoint>& previous_keypoints,
                                    const std::vector<cv::KeyPoint>& keypoints,
                                    const std::vector<FeatureStatus>& features, int* count);

class BoxPropagator {
 public:
  explicit BoxPropagator(const BoxPropagationOptions& options = {});

  // Boxes detected on the frame about to be filtered (velocities start at zero; Observe measures
  // them on this frame already).
  void SetDetections(const std::vector<Detection>& detections);
  // The boxes for the frame about to be filtered when the detector did not run on it: the current
  // boxes moved by their velocities. Becomes the current set.
  std::vector<Detection> Predict();
  // After the filter ran on the frame with the current boxes: updates each box's velocity from
  // the matches of this frame to the previous one.
  void Observe(const std::vector<cv::KeyPoint>& previous_keypoints,
               const std::vector<cv::KeyPoint>& keypoints, const FilterResult& result);
  void Reset();

  const std::vector<Detection>& boxes() const { return boxes_; }
  bool has_boxes() const { return has_boxes_; }

 private:
  BoxPropagationOptions options_;
  bool has_boxes_ = false;
  std::vector<Detection> boxes_;
  std::vector<cv::Point2f> velocities_;  // px per frame, one per box
};

}  // namespace dygslam
