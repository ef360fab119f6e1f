// A frame ready for tracking: undistorted keypoints, depth and virtual right coordinate per
// keypoint, descriptors, a grid for area queries, and the map-point associations being built.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "core/base/camera.h"
#include "core/base/rigid3.h"
#include "core/base/timestamp.h"
#include "core/place/vocabulary.h"
#include "core/slam/feature/orb_extractor.h"

namespace dygslam {

class MapPoint;
struct DenseView;

// Camera geometry shared by frames and keyframes (immutable once built).
struct CameraGeometry {
  PinholeCamera camera;
  double bf = 0;           // baseline * fx
  double close_depth = 0;  // ThDepth * baseline
  // Bounds of the undistorted image.
  double min_x = 0, max_x = 0, min_y = 0, max_y = 0;
  std::vector<double> scales, sigma2, inv_sigma2;
  double log_scale_factor = 0;
  int num_levels = 0;

  static CameraGeometry Create(const PinholeCamera& camera, const RgbdSensorOptions& sensor,
                               const OrbExtractor& extractor);
  bool InBounds(double u, double v) const {
    return u >= min_x && u < max_x && v >= min_y && v < max_y;
  }
};

// Uniform grid over the undistorted image for radius queries.
class FeatureGrid {
 public:
  static constexpr int kCols = 64, kRows = 48;
  void Build(const std::vector<cv::KeyPoint>& undistorted, const CameraGeometry& geometry);
  // Indices of keypoints within radius r (square window) of (u, v) with octave in
  // [min_level, max_level] (max_level < 0: no upper bound).
  std::vector<int> Query(const std::vector<cv::KeyPoint>& undistorted, double u, double v, double r,
                         int min_level = 0, int max_level = -1) const;

 private:
  double min_x_ = 0, min_y_ = 0, inv_cell_w_ = 0, inv_cell_h_ = 0;
  std::vector<std::vector<int>> cells_;
};

class Frame {
 public:
  // Unlinks the map points flagged as outliers (and clears the flags); returns the matches left
  // to points that have observations.
  int DiscardOutliers();
  Frame() = default;
  // depth_m: CV_32FC1 metres registered to the colour image.
  // in_dynamic_region (optional, one flag per feature): features inside detection boxes that the
  // filter kept. They are used for tracking against existing map points but never seed new ones.
  Frame(int64_t id, Timestamp stamp, OrbFeatures features, const cv::Mat& depth_m,
        std::shared_ptr<const CameraGeometry> geometry,
        std::vector<uint8_t> in_dynamic_region = {});

  int64_t id = -1;
  Timestamp stamp;
  std::shared_ptr<const CameraGeometry> geometry;
  std::vector<cv::KeyPoint> keypoints;    // distorted (image) coordinates
  std::vector<cv::KeyPoint> undistorted;  // undistorted coordinates
  std::vector<Descriptor> descriptors;
  std::vector<float> depth;                // metres, <= 0: none
  std::vector<float> u_right;              // virtual right coordinate, < 0: none
  std::vector<uint8_t> in_dynamic_region;  // 1: never seeds a map point
  bool CanSeedPoint(size_t i) const { return depth[i] > 0 && !in_dynamic_region[i]; }
  FeatureGrid grid;
  // Bag of words (empty until ComputeBow): relocalization, reference-keyframe tracking, loops.
  BowVector bow_vector;
  FeatureVector bow_features;  // direct index at kBowDirectIndexLevel
  static constexpr int kBowDirectIndexLevel = 2;
  void ComputeBow(const Vocabulary& vocabulary) {
    if (bow_vector.empty())
      vocabulary.Transform(descriptors, &bow_vector, &bow_features, kBowDirectIndexLevel);
  }
  // Gray image, depth and static mask, for the dense fallback estimator (null: none).
  std::shared_ptr<const DenseView> dense;

  // Tracking state built per frame.
  std::vector<std::shared_ptr<MapPoint>> map_points;
  std::vector<uint8_t> outlier;
  bool has_pose = false;
  Rigid3d cam_from_world;
  // The motion model's prediction of cam_from_world, when the frame follows one held by features
  // with a known velocity (a prior of the pose-only optimisation:
  // OptimizerOptions::pose_motion_prior).
  std::optional<Rigid3d> motion_prior;

  size_t size() const { return keypoints.size(); }
  Eigen::Vector3d CameraCenter() const { return cam_from_world.Inverse().translation; }
  // Back-projected keypoint i in world coordinates (requires depth and pose).
  Eigen::Vector3d UnprojectWorld(size_t i) const;
  int NumTrackedInliers() const;
};

}  // namespace dygslam
