#include "core/slam/map/frame.h"

#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>

#include "core/slam/map/map.h"

namespace dygslam {

CameraGeometry CameraGeometry::Create(const PinholeCamera& camera, const RgbdSensorOptions& sensor,
                                      const OrbExtractor& extractor) {
  CameraGeometry g;
  g.camera = camera;
  g.bf = sensor.bf;
  g.close_depth = sensor.close_depth(camera.fx);
  g.scales = extractor.scales();
  g.num_levels = extractor.num_levels();
  g.log_scale_factor = std::log(extractor.options().scale_factor);
  for (int l = 0; l < g.num_levels; ++l) {
    g.sigma2.push_back(extractor.sigma2(l));
    g.inv_sigma2.push_back(extractor.inv_sigma2(l));
  }
  if (camera.HasDistortion()) {
    std::vector<cv::Point2f> corners = {{0.f, 0.f},
                                        {float(camera.width), 0.f},
                                        {0.f, float(camera.height)},
                                        {float(camera.width), float(camera.height)}};
    std::vector<cv::Point2f> und;
    cv::undistortPoints(corners, und, camera.K(), camera.DistCoeffs(), cv::noArray(), camera.K());
    g.min_x = std::min(und[0].x, und[2].x);
    g.max_x = std::max(und[1].x, und[3].x);
    g.min_y = std::min(und[0].y, und[1].y);
    g.max_y = std::max(und[2].y, und[3].y);
  } else {
    g.min_x = 0;
    g.max_x = camera.width;
    g.min_y = 0;
    g.max_y = camera.height;
  }
  return g;
}

void FeatureGrid::Build(const std::vector<cv::KeyPoint>& undistorted, const CameraGeometry& g) {
  min_x_ = g.min_x;
  min_y_ = g.min_y;
  inv_cell_w_ = kCols / (g.max_x - g.min_x);
  inv_cell_h_ = kRows / (g.max_y - g.min_y);
  cells_.assign(kCols * kRows, {});
  for (int i = 0; i < static_cast<int>(undistorted.size()); ++i) {
    const int cx = static_cast<int>(std::floor((undistorted[i].pt.x - min_x_) * inv_cell_w_));
    const int cy = static_cast<int>(std::floor((undistorted[i].pt.y - min_y_) * inv_cell_h_));
    if (cx < 0 || cy < 0 || cx >= kCols || cy >= kRows) continue;
    cells_[cy * kCols + cx].push_back(i);
  }
}

std::vector<int> FeatureGrid::Query(const std::vector<cv::KeyPoint>& undistorted, double u,
                                    double v, double r, int min_level, int max_level) const {
  std::vector<int> result;
  if (cells_.empty()) return result;
  const int x0 = std::max(0, static_cast<int>(std::floor((u - r - min_x_) * inv_cell_w_)));
  const int x1 = std::min(kCols - 1, static_cast<int>(std::floor((u + r - min_x_) * inv_cell_w_)));
  const int y0 = std::max(0, static_cast<int>(std::floor((v - r - min_y_) * inv_cell_h_)));
  const int y1 = std::min(kRows - 1, static_cast<int>(std::floor((v + r - min_y_) * inv_cell_h_)));
  if (x0 > x1 || y0 > y1) return result;
  for (int cy = y0; cy <= y1; ++cy) {
    for (int cx = x0; cx <= x1; ++cx) {
      for (int i : cells_[cy * kCols + cx]) {
        const cv::KeyPoint& kp = undistorted[i];
        if (kp.octave < min_level) continue;
        if (max_level >= 0 && kp.octave > max_level) continue;
        if (std::abs(kp.pt.x - u) <= r && std::abs(kp.pt.y - v) <= r) result.push_back(i);
      }
    }
  }
  return result;
}

Frame::Frame(int64_t frame_id, Timestamp frame_stamp, OrbFeatures features, const cv::Mat& depth_m,
             std::shared_ptr<const CameraGeometry> frame_geometry,
             std::vector<uint8_t> dynamic_region)
    : id(frame_id),
      stamp(frame_stamp),
      geometry(std::move(frame_geometry)),
      keypoints(std::move(features.keypoints)),
      descriptors(std::move(features.descriptors)) {
  const PinholeCamera& cam = geometry->camera;
  const size_t n = keypoints.size();
  undistorted = keypoints;
  if (cam.HasDistortion() && n > 0) {
    std::vector<cv::Point2f> pts(n), und;
    for (size_t i = 0; i < n; ++i) pts[i] = keypoints[i].pt;
    cv::undistortPoints(pts, und, cam.K(), cam.DistCoeffs(), cv::noArray(), cam.K());
    for (size_t i = 0; i < n; ++i) undistorted[i].pt = und[i];
  }
  depth.assign(n, -1.f);
  u_right.assign(n, -1.f);
  for (size_t i = 0; i < n; ++i) {
    const int x = static_cast<int>(std::lround(keypoints[i].pt.x));
    const int y = static_cast<int>(std::lround(keypoints[i].pt.y));
    if (x < 0 || y < 0 || x >= depth_m.cols || y >= depth_m.rows) continue;
    const float d = depth_m.at<float>(y, x);
    if (d > 0 && std::isfinite(d)) {
      depth[i] = d;
      u_right[i] = static_cast<float>(undistorted[i].pt.x - geometry->bf / d);
    }
  }
  in_dynamic_region = std::move(dynamic_region);
  in_dynamic_region.resize(n, 0);
  grid.Build(undistorted, *geometry);
  map_points.assign(n, nullptr);
  outlier.assign(n, 0);
}

Eigen::Vector3d Frame::UnprojectWorld(size_t i) const {
  const cv::Point2f& p = undistorted[i].pt;
  const Eigen::Vector3d p_cam = geometry->camera.Unproject(p.x, p.y, depth[i]);
  return cam_from_world.Inverse() * p_cam;
}

int Frame::NumTrackedInliers() const {
  int n = 0;
  for (size_t i = 0; i < map_points.size(); ++i) {
    if (map_points[i] && !outlier[i]) ++n;
  }
  return n;
}

int Frame::DiscardOutliers() {
  int real = 0;
  for (size_t i = 0; i < size(); ++i) {
    if (!map_points[i]) continue;
    if (outlier[i]) {
      map_points[i] = nullptr;
      outlier[i] = 0;
    } else if (map_points[i]->NumObservations() > 0) {
      ++real;
    }
  }
  return real;
}

}  // namespace dygslam
