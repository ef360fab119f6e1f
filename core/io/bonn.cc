#include "core/io/bonn.h"

#include <Eigen/SVD>

#include "core/io/dataset.h"
#include "core/io/trajectory_io.h"

namespace dygslam {

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

std::vector<GroundTruthDepthFrame> LoadGroundTruthDepthFrames(const std::string& directory,
                                                              int every, double depth_factor) {
  const RgbdDataset dataset = RgbdDataset::Open(directory);
  const std::vector<StampedPose> groundtruth = ReadTumTrajectory(directory + "/groundtruth.txt");
  std::vector<GroundTruthDepthFrame> frames;
  for (size_t i = 0; i < dataset.size(); i += static_cast<size_t>(every)) {
    const Timestamp stamp = dataset.frame(i).depth_stamp;
    const auto pose = InterpolatePose(groundtruth, stamp);
    if (!pose) continue;
    GroundTruthDepthFrame f;
    f.index = i;
    f.stamp = stamp;
    dataset.LoadDepth(i).convertTo(f.depth, CV_32FC1, 1.0 / depth_factor);
    f.world_from_body = *pose;
    frames.push_back(std::move(f));
  }
  return frames;
}

}  // namespace dygslam
