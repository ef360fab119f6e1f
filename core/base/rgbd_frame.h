// One RGB-D frame: colour and depth of one instant, as a camera, a dataset folder, a DDS message
// or a ROS 2 image pair delivers it, plus what the System may be given with it (a feature mask,
// person boxes found elsewhere). The one frame type of the project: the dataset runner,
// the slam component (components/convert.h RgbdFrameData adds the wire header to it) and the
// ROS 2 synchroniser (bridge/rgbd_sync.h) all make it; System::FeedRgbdFrame takes it.
//
// Depth stays as delivered (raw 16-bit counts with their scale, or metres) and is converted to
// metres once, by the System (DepthInMetres).
#pragma once

#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "core/base/timestamp.h"
#include "core/base/types.h"

namespace dygslam {

struct RgbdFrame {
  Timestamp stamp;
  cv::Mat rgb;  // CV_8UC3 BGR (CV_8UC1 grey is tracked too, but the System's detector needs BGR)
  // CV_16UC1 raw counts or CV_32FC1 metres; 0 = no measurement. Registered to the colour image.
  cv::Mat depth;
  // Raw depth / depth_scale = metres (CV_16UC1 only). TUM / Bonn / ORB-SLAM2's DepthMapFactor is
  // 5000, the same default as RgbdSensorOptions::depth_map_factor; ROS 2 drivers: 1000.
  double depth_scale = 5000.0;
  // Optional CV_8UC1, nonzero = no features there.
  cv::Mat mask;
  // Person boxes found elsewhere (the detector component, a detections file), used as given; an
  // empty list means "no boxes on this frame". nullopt: the System runs its own detector when
  // its filter mode needs boxes.
  std::optional<std::vector<Detection>> detections;

  // Depth in metres, CV_32FC1: raw depth divided by depth_scale (a new image), or the CV_32FC1
  // depth itself (shared, not copied). Throws InputError for another depth type or a depth_scale
  // that is not a finite number > 0.
  cv::Mat DepthInMetres() const;
};

// Throws InputError naming the image ("rgb image", "depth image", "mask") and what is wrong: an
// empty image, a type other than the ones above, a size other than width x height (the camera's),
// a raw depth without a usable depth_scale.
void CheckRgbdFrame(const RgbdFrame& frame, int width, int height);

}  // namespace dygslam
