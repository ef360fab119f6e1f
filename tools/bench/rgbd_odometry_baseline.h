// The side-by-side baseline of `dygslam bench`: OpenCV contrib's frame-to-frame RGB-D odometry
// (cv::rgbd::RgbdICPOdometry: photometric + point-to-plane ICP on image/depth pyramids), the thing
// users reach for when they need RGB-D poses without a SLAM system.
//
//   RgbdOdometryBaseline odometry(camera, depth_map_factor, RgbdOdometryOptions());
//   for (...) {
//     OdometryStep step = odometry.Track(bgr, raw_depth, stamp);
//   }
//   std::vector<StampedPose> trajectory = odometry.Trajectory();
//
// The pose of the first frame is the identity (world = first camera). Every frame gets a pose:
// when OpenCV rejects a step (too few correspondences, or a jump beyond max_translation /
// max_rotation_deg), the previous pose is kept (constant-position fallback) and the step is
// counted as failed.
#pragma once

#include <memory>
#include <opencv2/core.hpp>
#include <vector>

#include "core/base/camera.h"
#include "core/base/error.h"
#include "core/base/types.h"

namespace cv::rgbd {
class RgbdICPOdometry;
struct OdometryFrame;
}  // namespace cv::rgbd

namespace dygslam {

struct RgbdOdometryOptions {
  // OpenCV's defaults (cv::rgbd::Odometry::DEFAULT_*), except max_depth: 4 m -> 6 m (Bonn rooms).
  double min_depth = 0.0;                             // metres
  double max_depth = 6.0;                             // metres
  double max_depth_diff = 0.07;                       // metres, correspondence rejection
  double max_points_part = 0.07;                      // share of pixels used per pyramid level
  std::vector<int> iteration_counts = {7, 7, 7, 10};  // coarse levels last (OpenCV order)
  // Accepted motion between consecutive frames (OpenCV's checks).
  double max_translation = 0.15;  // metres
  double max_rotation_deg = 15.0;
  // Use the previous step as the initial guess (constant velocity).
  bool constant_velocity_guess = true;
  void Check() const;
};

struct OdometryStep {
  Timestamp stamp;
  Rigid3d world_from_cam;
  bool ok = true;      // false: OpenCV rejected the step, previous pose kept
  double time_ms = 0;  // frame preparation + odometry (not image loading)
};

class RgbdOdometryBaseline {
 public:
  // depth_map_factor: raw CV_16UC1 depth / factor = metres. Throws InvalidOptions.
  RgbdOdometryBaseline(const PinholeCamera& camera, double depth_map_factor,
                       const RgbdOdometryOptions& options = {});
  ~RgbdOdometryBaseline();
  RgbdOdometryBaseline(const RgbdOdometryBaseline&) = delete;
  RgbdOdometryBaseline& operator=(const RgbdOdometryBaseline&) = delete;

  // bgr: CV_8UC3 (or CV_8UC1 gray). depth: CV_16UC1 raw or CV_32FC1 metres. Throws InputError on
  // empty images or a size mismatch with the camera.
  OdometryStep Track(const cv::Mat& bgr, const cv::Mat& depth, Timestamp stamp);

  const std::vector<StampedPose>& Trajectory() const { return trajectory_; }
  int num_failed() const { return num_failed_; }

 private:
  PinholeCamera camera_;
  double depth_map_factor_;
  RgbdOdometryOptions options_;
  cv::Ptr<cv::rgbd::RgbdICPOdometry> odometry_;
  cv::Ptr<cv::rgbd::OdometryFrame> previous_;
  cv::Mat last_step_;  // 4x4 CV_64F, previous dst_from_src
  Rigid3d world_from_cam_;
  std::vector<StampedPose> trajectory_;
  int num_failed_ = 0;
};

}  // namespace dygslam
