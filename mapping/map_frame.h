// A gravity-aligned frame for a map built in the SLAM world (= the first camera frame, x right,
// y down, z forward): finds the floor among the occupied cells and gives a z-up frame with the
// floor at z = 0, so top views and slices of the map are level.
//
// The floor is the plane with the most occupied cells (RANSAC over cell centres, then a
// least-squares fit to its inliers) among planes whose normal is within max_tilt_deg of
// `prior_up` (e.g. "up" in the first image, -y of the first camera) and that lie at least
// min_depth_below below `camera_position`. Walls (normals far from the prior) and the ceiling
// (above the camera) do not qualify. Deterministic (fixed seed).
#pragma once

#include <octomap/OcTree.h>

#include <Eigen/Core>
#include <cstdint>

#include "core/base/rigid3.h"

namespace dygslam {

struct FloorOptions {
  double max_tilt_deg = 35.0;    // between the floor normal and prior_up
  double min_depth_below = 0.5;  // m, floor below the camera
  double inlier_distance = 0.0;  // m; <= 0: the map's resolution
  int iterations = 300;
  size_t min_inliers = 200;  // cells, else no floor
  uint64_t seed = 1;
  void Check() const;
};

struct FloorEstimate {
  bool found = false;
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();  // unit normal, pointing to the camera side
  double offset = 0;                              // up . p = offset on the floor
  size_t num_inliers = 0;
  double tilt_from_prior_deg = 0;
};

FloorEstimate EstimateFloor(const octomap::OcTree& map, const Eigen::Vector3d& prior_up,
                            const Eigen::Vector3d& camera_position,
                            const FloorOptions& options = {});

// aligned_from_world: z = floor.up (floor at z = 0 when found; else z = 0 at the camera),
// y = the camera's viewing direction projected on the floor, x = y x z; the camera is above the
// origin. Without a floor, prior_up is used as the up direction.
Rigid3d LevelFrameFromWorld(const FloorEstimate& floor, const Eigen::Vector3d& prior_up,
                            const Rigid3d& world_from_cam);

}  // namespace dygslam
