#include "mapping/bonn_frames.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "core/base/error.h"

namespace dygslam::mapping_data {

PinholeCamera BonnCamera() {
  PinholeCamera camera;
  camera.fx = 542.822841;
  camera.fy = 542.576870;
  camera.cx = 315.593520;
  camera.cy = 237.756098;
  camera.width = 640;
  camera.height = 480;
  return camera;
}

Rigid3d BonnMarkerFromCam() {
  Eigen::Matrix3d ros;
  ros << -1, 0, 0, 0, 0, 1, 0, 1, 0;
  Eigen::Matrix3d m;
  m << 1.0157, 0.1828, -0.2389, 0.0009, -0.8431, -0.6413, -0.3009, 0.6147, -0.8085;
  const Eigen::Vector3d t(0.0113, -0.0098, 0.0111);
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d r = svd.matrixU() * svd.matrixV().transpose();
  if (r.determinant() < 0) r = -r;
  return Rigid3d(ros, Eigen::Vector3d::Zero()) * Rigid3d(r, t);
}

std::vector<DepthEntry> ReadDepthList(const std::string& dir) {
  const std::string path = dir + "/depth.txt";
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, "cannot open");
  std::vector<DepthEntry> entries;
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    std::string stamp_text, file;
    if (!(fields >> stamp_text >> file))
      throw InputError(path, line_no, "expected 'timestamp path'");
    const auto stamp = Timestamp::Parse(stamp_text);
    if (!stamp) throw InputError(path, line_no, "bad timestamp '" + stamp_text + "'");
    entries.push_back({*stamp, dir + "/" + file});
  }
  return entries;
}

std::vector<StampedPose> ReadTrajectory(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, "cannot open");
  std::vector<StampedPose> poses;
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    std::string stamp_text;
    double v[7];
    if (!(fields >> stamp_text >> v[0] >> v[1] >> v[2] >> v[3] >> v[4] >> v[5] >> v[6])) {
      throw InputError(path, line_no, "expected 't tx ty tz qx qy qz qw'");
    }
    const auto stamp = Timestamp::Parse(stamp_text);
    if (!stamp) throw InputError(path, line_no, "bad timestamp '" + stamp_text + "'");
    if (!poses.empty() && !(poses.back().stamp < *stamp)) {
      throw InputError(path, line_no, "timestamps not increasing");
    }
    const Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
    if (std::abs(q.norm() - 1.0) > 1e-2) throw InputError(path, line_no, "quaternion not unit");
    poses.push_back({*stamp, Rigid3d(q, Eigen::Vector3d(v[0], v[1], v[2]))});
  }
  return poses;
}

std::optional<Rigid3d> InterpolatePose(const std::vector<StampedPose>& trajectory, Timestamp stamp,
                                       double max_gap) {
  auto after = std::lower_bound(trajectory.begin(), trajectory.end(), stamp,
                                [](const StampedPose& p, Timestamp t) { return p.stamp < t; });
  if (after == trajectory.end()) return std::nullopt;
  if (after->stamp == stamp) return after->world_from_cam;
  if (after == trajectory.begin()) return std::nullopt;
  const auto before = after - 1;
  const double gap = SecondsBetween(before->stamp, after->stamp);
  if (gap > max_gap) return std::nullopt;
  const double s = SecondsBetween(before->stamp, stamp) / gap;
  const Rigid3d& a = before->world_from_cam;
  const Rigid3d& b = after->world_from_cam;
  return Rigid3d(a.rotation.slerp(s, b.rotation), (1 - s) * a.translation + s * b.translation);
}

cv::Mat LoadDepthMetres(const std::string& path, double depth_factor) {
  const cv::Mat raw = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (raw.empty()) throw InputError(path, 0, "cannot read depth image");
  if (raw.type() != CV_16UC1) throw InputError(path, 0, "depth image is not 16-bit single channel");
  cv::Mat metres;
  raw.convertTo(metres, CV_32FC1, 1.0 / depth_factor);
  return metres;
}

}  // namespace dygslam::mapping_data
