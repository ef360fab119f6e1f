// Pinhole camera with Brown-Conrady distortion (OpenCV / ORB-SLAM2 k1,k2,p1,p2,k3) and the
// RGB-D sensor settings of ORB-SLAM2's YAML (Camera.bf, ThDepth, DepthMapFactor).
#pragma once

#include <cmath>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "core/base/error.h"

namespace dygslam {

struct PinholeCamera {
  double fx = 0, fy = 0, cx = 0, cy = 0;
  double k1 = 0, k2 = 0, p1 = 0, p2 = 0, k3 = 0;
  int width = 640, height = 480;

  bool HasDistortion() const { return k1 != 0 || k2 != 0 || p1 != 0 || p2 != 0 || k3 != 0; }
  Eigen::Vector2d Project(const Eigen::Vector3d& p_cam) const {
    return {fx * p_cam.x() / p_cam.z() + cx, fy * p_cam.y() / p_cam.z() + cy};
  }
  Eigen::Vector3d Unproject(double u, double v, double depth) const {
    return {(u - cx) / fx * depth, (v - cy) / fy * depth, depth};
  }
  bool InImage(double u, double v) const { return u >= 0 && v >= 0 && u < width && v < height; }
  cv::Mat K() const { return (cv::Mat_<double>(3, 3) << fx, 0, cx, 0, fy, cy, 0, 0, 1); }
  cv::Mat DistCoeffs() const { return (cv::Mat_<double>(1, 5) << k1, k2, p1, p2, k3); }
  void Check() const {
    DYGSLAM_CHECK_OPTION(fx > 0 && std::isfinite(fx), "Camera.fx");
    DYGSLAM_CHECK_OPTION(fy > 0 && std::isfinite(fy), "Camera.fy");
    DYGSLAM_CHECK_OPTION(std::isfinite(cx), "Camera.cx");
    DYGSLAM_CHECK_OPTION(std::isfinite(cy), "Camera.cy");
    DYGSLAM_CHECK_OPTION(std::isfinite(k1) && std::isfinite(k2) && std::isfinite(p1) &&
                             std::isfinite(p2) && std::isfinite(k3),
                         "Camera.k1/k2/p1/p2/k3");
    DYGSLAM_CHECK_OPTION(width > 0 && width <= 16384, "Camera.width");
    DYGSLAM_CHECK_OPTION(height > 0 && height <= 16384, "Camera.height");
  }
};

struct RgbdSensorOptions {
  double fps = 30.0;
  // Stereo baseline times fx (ORB-SLAM2's Camera.bf); defines the virtual right coordinate.
  double bf = 40.0;
  // Close/far threshold in baselines: points closer than ThDepth * bf / fx are "close".
  double th_depth = 40.0;
  // raw depth value / DepthMapFactor = metres (TUM/Bonn: 5000).
  double depth_map_factor = 5000.0;

  double baseline(double fx) const { return bf / fx; }
  double close_depth(double fx) const { return th_depth * bf / fx; }
  void Check() const {
    DYGSLAM_CHECK_OPTION(fps > 0 && std::isfinite(fps), "Camera.fps");
    DYGSLAM_CHECK_OPTION(bf > 0 && std::isfinite(bf), "Camera.bf");
    DYGSLAM_CHECK_OPTION(th_depth > 0 && std::isfinite(th_depth), "ThDepth");
    DYGSLAM_CHECK_OPTION(depth_map_factor > 0 && std::isfinite(depth_map_factor), "DepthMapFactor");
  }
};

}  // namespace dygslam
