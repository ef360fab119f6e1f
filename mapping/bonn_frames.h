// Minimal reader for the shared Bonn/TUM frames used by the mapping tests and benchmark: depth
// list, ground-truth trajectory with interpolation. (The general dataset reader is core/io; this
// keeps the mapping tests independent of it.)
#pragma once

#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/base/camera.h"
#include "core/base/types.h"

namespace dygslam::mapping_data {

struct DepthEntry {
  Timestamp stamp;
  std::string path;  // absolute
};

// Bonn RGB-D Dynamic intrinsics (640x480).
PinholeCamera BonnCamera();

// The Bonn ground truth is the pose of the motion-capture marker body, not of the camera:
// world_from_cam = groundtruth * BonnMarkerFromCam(). This is the dataset authors' published
// marker-to-camera calibration (T_ros * T_m, rotation orthonormalised; the T_ros applied on the
// left in their formula only rotates the world frame and is left out, so the world stays z-up).
// Checked on the shared frames (dygslam_mapping_benchmark --check-marker): frames 50-99 land in
// occupied 5 cm cells of the map of frames 0-49 for 50 % of their points with it, 18 % with the
// raw body pose, <= 27 % with any axis-aligned rotation; the map has 37 % fewer occupied cells.
Rigid3d BonnMarkerFromCam();

// "<dir>/depth.txt" entries. Throws InputError naming file and line.
std::vector<DepthEntry> ReadDepthList(const std::string& dir);
// TUM trajectory "t tx ty tz qx qy qz qw". Throws InputError naming file and line.
std::vector<StampedPose> ReadTrajectory(const std::string& path);
// Pose at `stamp` by linear/slerp interpolation between the neighbouring samples; nullopt if
// outside the trajectory or the neighbours are more than max_gap seconds apart.
std::optional<Rigid3d> InterpolatePose(const std::vector<StampedPose>& trajectory, Timestamp stamp,
                                       double max_gap = 0.1);
// CV_32FC1 metres from a 16-bit depth PNG (value / depth_factor). Throws InputError.
cv::Mat LoadDepthMetres(const std::string& path, double depth_factor = 5000.0);

}  // namespace dygslam::mapping_data
