// Per-pixel dynamic mask of a keyframe for the map (KeyframeData::dynamic_mask): the detector
// boxes refined by depth, plus disks around the features the filter judged dynamic. The map then
// leaves the people out without deleting the wall behind them.
//
// Inside each box the object's depth is the box's foreground depth: the nearest depth d whose band
// [d, d + depth_band] holds at least foreground_min_fraction of the box's valid depth pixels
// (BoxObjectDepth). It does not depend on which in-box features the filter kept (labels that
// keep more in-box features static must not shrink the map's masks; the median depth of the
// dynamic features was measured no better);
// and the box pixels whose depth is within [object - depth_band, object + depth_band] are masked,
// as are the box pixels without depth (they carry nothing for the map anyway). A box without any
// valid depth is masked entirely. Finally the mask is dilated by dilation_px and disks of
// feature_radius px are drawn around every dynamic feature that has no depth or whose depth is
// within depth_band of its box's object depth (features outside boxes: always).
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "core/base/error.h"
#include "core/base/types.h"

namespace dygslam {

struct DynamicMaskOptions {
  double depth_band = 0.5;  // m, half-width of the object depth band (a person is ~0.3-0.5 m deep)
  double foreground_min_fraction = 0.15;
  double histogram_bin = 0.05;  // m
  int dilation_px = 3;
  int feature_radius = 8;   // px
  double box_margin = 0.0;  // px added on each side of the boxes
  void Check() const;
};

// The object depth of a box (metres): the nearest depth d whose band [d, d + depth_band] holds at
// least foreground_min_fraction of the valid depth pixels in `box` (clipped to the image); NaN
// when the box has no valid depth. depth: CV_32FC1 metres (0 or non-finite = none).
double BoxObjectDepth(const cv::Mat& depth, const cv::Rect& box,
                      const DynamicMaskOptions& options = DynamicMaskOptions());

// depth: CV_32FC1 metres (0 or non-finite = no measurement) or empty (then the boxes are masked
// entirely). keypoint_dynamic: same size as keypoints (1 = dynamic) or empty. Returns CV_8UC1 of
// `image_size` (or depth's size if not empty), 255 = dynamic.
cv::Mat ComputeDynamicMask(const cv::Size& image_size, const cv::Mat& depth,
                           const std::vector<Detection>& detections,
                           const std::vector<cv::KeyPoint>& keypoints,
                           const std::vector<uint8_t>& keypoint_dynamic,
                           const DynamicMaskOptions& options = DynamicMaskOptions());

}  // namespace dygslam
