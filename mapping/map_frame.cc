#include "mapping/map_frame.h"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <random>
#include <vector>

#include "core/base/error.h"

namespace dygslam {
namespace {
constexpr double kPi = 3.14159265358979323846;
}

void FloorOptions::Check() const {
  DYGSLAM_CHECK_OPTION(max_tilt_deg > 0 && max_tilt_deg < 90, "Floor.max_tilt_deg");
  DYGSLAM_CHECK_OPTION(min_depth_below >= 0, "Floor.min_depth_below");
  DYGSLAM_CHECK_OPTION(std::isfinite(inlier_distance), "Floor.inlier_distance");
  DYGSLAM_CHECK_OPTION(iterations >= 1, "Floor.iterations");
}

FloorEstimate EstimateFloor(const octomap::OcTree& map, const Eigen::Vector3d& prior_up,
                            const Eigen::Vector3d& camera_position, const FloorOptions& options) {
  options.Check();
  const Eigen::Vector3d prior = prior_up.normalized();
  const double cos_max = std::cos(options.max_tilt_deg * kPi / 180.0);
  const double tolerance =
      options.inlier_distance > 0 ? options.inlier_distance : map.getResolution();
  // Candidate cells: occupied leaves' centres below the camera (along the prior).
  std::vector<Eigen::Vector3d> points;
  const double camera_height = prior.dot(camera_position);
  for (auto it = map.begin_leafs(), end = map.end_leafs(); it != end; ++it) {
    if (!map.isNodeOccupied(*it)) continue;
    const Eigen::Vector3d p(it.getX(), it.getY(), it.getZ());
    if (prior.dot(p) < camera_height - options.min_depth_below) points.push_back(p);
  }
  FloorEstimate best;
  if (points.size() < 3) return best;
  std::mt19937_64 rng(options.seed);
  std::uniform_int_distribution<size_t> pick(0, points.size() - 1);
  auto count = [&](const Eigen::Vector3d& n, double d, std::vector<size_t>* inliers) {
    size_t c = 0;
    for (size_t i = 0; i < points.size(); ++i) {
      if (std::abs(n.dot(points[i]) - d) <= tolerance) {
        ++c;
        if (inliers) inliers->push_back(i);
      }
    }
    return c;
  };
  Eigen::Vector3d best_n = prior;
  double best_d = 0;
  size_t best_count = 0;
  for (int iter = 0; iter < options.iterations; ++iter) {
    const Eigen::Vector3d& a = points[pick(rng)];
    const Eigen::Vector3d& b = points[pick(rng)];
    const Eigen::Vector3d& c = points[pick(rng)];
    Eigen::Vector3d n = (b - a).cross(c - a);
    if (n.norm() < 1e-9) continue;
    n.normalize();
    if (n.dot(prior) < 0) n = -n;
    if (n.dot(prior) < cos_max) continue;
    const double d = n.dot(a);
    const size_t inliers = count(n, d, nullptr);
    if (inliers > best_count) {
      best_count = inliers;
      best_n = n;
      best_d = d;
    }
  }
  if (best_count < std::max<size_t>(options.min_inliers, 3)) return best;
  // Least-squares refinement on the inliers (smallest principal axis).
  std::vector<size_t> inliers;
  count(best_n, best_d, &inliers);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (size_t i : inliers) mean += points[i];
  mean /= static_cast<double>(inliers.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (size_t i : inliers) cov += (points[i] - mean) * (points[i] - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(cov);
  Eigen::Vector3d n = solver.eigenvectors().col(0).normalized();
  if (n.dot(prior) < 0) n = -n;
  if (n.dot(prior) < cos_max) n = best_n;  // degenerate fit: keep the RANSAC plane
  best.found = true;
  best.up = n;
  best.offset = n.dot(mean);
  best.num_inliers = inliers.size();
  best.tilt_from_prior_deg = std::acos(std::min(1.0, n.dot(prior))) * 180.0 / kPi;
  return best;
}

Rigid3d LevelFrameFromWorld(const FloorEstimate& floor, const Eigen::Vector3d& prior_up,
                            const Rigid3d& world_from_cam) {
  const Eigen::Vector3d z = floor.found ? floor.up : prior_up.normalized();
  const Eigen::Vector3d forward = world_from_cam.rotation * Eigen::Vector3d::UnitZ();
  Eigen::Vector3d y = forward - forward.dot(z) * z;
  if (y.norm() < 1e-6) {  // looking straight down/up: use the image's x instead
    const Eigen::Vector3d right = world_from_cam.rotation * Eigen::Vector3d::UnitX();
    y = z.cross(right);
  }
  y.normalize();
  const Eigen::Vector3d x = y.cross(z);
  Eigen::Matrix3d rotation;  // rows: the new axes in world coordinates
  rotation.row(0) = x.transpose();
  rotation.row(1) = y.transpose();
  rotation.row(2) = z.transpose();
  const Eigen::Vector3d c = world_from_cam.translation;
  // Camera above the origin; floor at z = 0 (or the camera at z = 0 without a floor).
  const Eigen::Vector3d translation(-x.dot(c), -y.dot(c), floor.found ? -floor.offset : -z.dot(c));
  return Rigid3d(Eigen::Quaterniond(rotation), translation);
}

}  // namespace dygslam
