#include "tools/bench/rgbd_odometry_baseline.h"

#include <chrono>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <opencv2/rgbd.hpp>

namespace dygslam {

void RgbdOdometryOptions::Check() const {
  DYGSLAM_CHECK_OPTION(min_depth >= 0 && std::isfinite(min_depth), "min_depth");
  DYGSLAM_CHECK_OPTION(max_depth > min_depth && std::isfinite(max_depth), "max_depth");
  DYGSLAM_CHECK_OPTION(max_depth_diff > 0 && std::isfinite(max_depth_diff), "max_depth_diff");
  DYGSLAM_CHECK_OPTION(max_points_part > 0 && max_points_part <= 1, "max_points_part");
  DYGSLAM_CHECK_OPTION(!iteration_counts.empty(), "iteration_counts");
  for (int n : iteration_counts) DYGSLAM_CHECK_OPTION(n > 0, "iteration_counts");
  DYGSLAM_CHECK_OPTION(max_translation > 0, "max_translation");
  DYGSLAM_CHECK_OPTION(max_rotation_deg > 0, "max_rotation_deg");
}

RgbdOdometryBaseline::RgbdOdometryBaseline(const PinholeCamera& camera, double depth_map_factor,
                                           const RgbdOdometryOptions& options)
    : camera_(camera), depth_map_factor_(depth_map_factor), options_(options) {
  camera_.Check();
  DYGSLAM_CHECK_OPTION(depth_map_factor > 0 && std::isfinite(depth_map_factor), "DepthMapFactor");
  options_.Check();
  cv::Mat K;
  camera_.K().convertTo(K, CV_32F);
  odometry_ = cv::makePtr<cv::rgbd::RgbdICPOdometry>(
      K, static_cast<float>(options_.min_depth), static_cast<float>(options_.max_depth),
      static_cast<float>(options_.max_depth_diff), static_cast<float>(options_.max_points_part),
      options_.iteration_counts);
  odometry_->setMaxTranslation(options_.max_translation);
  odometry_->setMaxRotation(options_.max_rotation_deg);
}

RgbdOdometryBaseline::~RgbdOdometryBaseline() = default;

OdometryStep RgbdOdometryBaseline::Track(const cv::Mat& bgr, const cv::Mat& depth,
                                         Timestamp stamp) {
  if (bgr.empty() || (bgr.type() != CV_8UC3 && bgr.type() != CV_8UC1))
    throw InputError("odometry: rgb image must be CV_8UC3 or CV_8UC1");
  if (depth.empty() || (depth.type() != CV_16UC1 && depth.type() != CV_32FC1))
    throw InputError("odometry: depth image must be CV_16UC1 or CV_32FC1");
  if (bgr.cols != camera_.width || bgr.rows != camera_.height || depth.size() != bgr.size())
    throw InputError("odometry: image size does not match Camera.width/height");
  const auto t0 = std::chrono::steady_clock::now();
  cv::Mat gray;
  if (bgr.channels() == 3) {
    cv::cvtColor(bgr, gray, cv::COLOR_BGR2GRAY);
  } else {
    gray = bgr;
  }
  cv::Mat depth_m;
  if (depth.type() == CV_16UC1) {
    depth.convertTo(depth_m, CV_32F, 1.0 / depth_map_factor_);
  } else {
    depth_m = depth.clone();
  }
  // OpenCV expects NaN (not 0) for missing depth in some code paths; both are rejected by the
  // min/max depth test, but NaN is the documented "no measurement".
  depth_m.setTo(std::numeric_limits<float>::quiet_NaN(), depth_m == 0);

  cv::Ptr<cv::rgbd::OdometryFrame> current =
      cv::makePtr<cv::rgbd::OdometryFrame>(gray, depth_m, cv::Mat(), cv::Mat(), -1);
  OdometryStep step;
  step.stamp = stamp;
  if (previous_) {
    cv::Mat dst_from_src;  // current_from_previous: p_current = Rt * p_previous
    const cv::Mat init = options_.constant_velocity_guess ? last_step_ : cv::Mat();
    cv::Ptr<cv::rgbd::OdometryFrame> src = previous_;
    const bool ok = odometry_->compute(src, current, dst_from_src, init);
    if (ok && dst_from_src.type() == CV_64FC1 && cv::checkRange(dst_from_src)) {
      Eigen::Matrix3d r;
      Eigen::Vector3d t;
      for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) r(i, j) = dst_from_src.at<double>(i, j);
        t(i) = dst_from_src.at<double>(i, 3);
      }
      const Rigid3d current_from_previous(r, t);
      world_from_cam_ = world_from_cam_ * current_from_previous.Inverse();
      last_step_ = dst_from_src.clone();
    } else {
      step.ok = false;
      ++num_failed_;
      last_step_ = cv::Mat();
    }
  } else {
    odometry_->prepareFrameCache(current, cv::rgbd::OdometryFrame::CACHE_ALL);
  }
  previous_ = current;
  step.world_from_cam = world_from_cam_;
  step.time_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  trajectory_.push_back(StampedPose{stamp, world_from_cam_});
  return step;
}

}  // namespace dygslam
