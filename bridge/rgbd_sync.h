// Pairs colour and depth images from a ROS 2 camera driver by stamp (no DDS) into the core's
// RgbdFrame (core/base/rgbd_frame.h): the colour image's stamp and image, its depth partner's
// image and depth_scale.
//
// Drivers publish aligned depth with the colour stamp (RealSense, Azure Kinect), so pairs are
// usually exact; other drivers are a few ms apart. A colour image is paired with the depth image
// of nearest stamp once that choice is final (an exact match, or a depth at or after the colour
// stamp is already queued: later depths can only be further away) and |difference| <=
// max_stamp_difference_s. A colour image that can no longer find a partner within the tolerance
// is dropped, as are depth images older than a pair just formed. Images whose stamp does not
// increase are dropped (out of order / duplicates). Each queue holds at most max_queue images
// (oldest dropped), so an absent partner stream costs bounded memory.
#pragma once

#include <cstddef>
#include <deque>
#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "core/base/rgbd_frame.h"
#include "core/base/timestamp.h"

namespace dygslam::ros2 {

struct RgbdSyncOptions {
  double max_stamp_difference_s = 0.02;
  size_t max_queue = 16;
  void Check() const;
};

struct StampedImage {
  Timestamp stamp;
  cv::Mat image;
  double depth_scale = 1.0;  // depth only: raw / depth_scale = metres
};

struct RgbdSyncStats {
  size_t pairs = 0;
  size_t dropped_color = 0;  // no depth within the tolerance, queue overflow, out of order
  size_t dropped_depth = 0;
};

class RgbdSynchronizer {
 public:
  explicit RgbdSynchronizer(const RgbdSyncOptions& options);
  // Each returns the frames completed by this image, in stamp order.
  std::vector<RgbdFrame> AddColor(StampedImage color);
  std::vector<RgbdFrame> AddDepth(StampedImage depth);
  const RgbdSyncStats& stats() const { return stats_; }
  size_t pending_color() const { return colors_.size(); }
  size_t pending_depth() const { return depths_.size(); }

 private:
  std::vector<RgbdFrame> Match();
  // Queues `image` behind `last` (dropped when its stamp does not increase, or the oldest when
  // the queue is full), counting drops in `dropped`; then matches.
  std::vector<RgbdFrame> Add(StampedImage image, std::deque<StampedImage>* queue,
                             std::optional<Timestamp>* last, size_t* dropped);
  RgbdSyncOptions options_;
  int64_t tolerance_ns_ = 0;
  std::deque<StampedImage> colors_, depths_;
  std::optional<Timestamp> last_color_, last_depth_;
  RgbdSyncStats stats_;
};

}  // namespace dygslam::ros2
