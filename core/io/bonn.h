// Bonn RGB-D Dynamic specifics (intrinsics, the ground truth's marker-to-camera calibration) and
// the depth frames of a dataset with their ground-truth poses, for mapping tests and benchmarks
// that build maps from ground truth instead of SLAM.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "core/base/camera.h"
#include "core/base/rigid3.h"
#include "core/base/timestamp.h"

namespace dygslam {

// Bonn RGB-D Dynamic intrinsics (640x480), as in config/bonn.yaml.
PinholeCamera BonnCamera();

// The Bonn ground truth is the pose of the motion-capture marker body, not of the camera:
// world_from_cam = groundtruth * BonnMarkerFromCam(). This is the dataset authors' published
// marker-to-camera calibration (T_ros * T_m, rotation orthonormalised; the T_ros applied on the
// left in their formula only rotates the world frame and is left out, so the world stays z-up).
// Checked on the shared frames (dygslam_mapping_benchmark --check-marker): frames 50-99 land in
// occupied 5 cm cells of the map of frames 0-49 for 50 % of their points with it, 18 % with the
// raw body pose, <= 27 % with any axis-aligned rotation; the map has 37 % fewer occupied cells.
Rigid3d BonnMarkerFromCam();

struct GroundTruthDepthFrame {
  size_t index = 0;         // frame index in the dataset (rgb/depth pairs)
  Timestamp stamp;          // the depth image's
  cv::Mat depth;            // CV_32FC1 metres
  Rigid3d world_from_body;  // ground truth interpolated at `stamp` (Bonn: the marker body)
};

// Every `every`-th frame of the dataset in `directory` that its groundtruth.txt covers (pose
// interpolated at the depth stamp; frames outside it are skipped). Throws InputError naming the
// file for a missing or malformed list, ground truth or image.
std::vector<GroundTruthDepthFrame> LoadGroundTruthDepthFrames(const std::string& directory,
                                                              int every,
                                                              double depth_factor = 5000.0);

}  // namespace dygslam
