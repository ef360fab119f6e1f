// Box-room RGB-D scene for the mapping tests: a closed box room with static furniture boxes and
// optional moving boxes (person-sized), rendered analytically (exact depth, exact dynamic mask).
// World frame: z up. Camera frame: optical (x right, y down, z forward).
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <vector>

#include "core/base/camera.h"
#include "core/base/rigid3.h"
#include "core/base/types.h"

namespace dygslam::box_room {

struct Box {
  Eigen::Vector3d min, max;
  bool Contains(const Eigen::Vector3d& p, double margin = 0) const {
    return (p.array() >= min.array() - margin).all() && (p.array() <= max.array() + margin).all();
  }
};

struct Scene {
  Box room;  // seen from inside
  std::vector<Box> static_boxes;
  std::vector<Box> dynamic_boxes;  // rendered into depth and into dynamic_mask
};

// 5.04 x 4.04 x 2.5 m room (walls off the 5 cm grid), a cabinet and a shelf.
Scene DefaultRoom();
// Small camera for fast tests: 160x120, f = 120.
PinholeCamera SmallCamera();
// Camera at `position` looking along world direction `yaw` (radians about z, 0 = +x), level.
Rigid3d LookingAlong(const Eigen::Vector3d& position, double yaw);

// Depth (CV_32FC1 metres) and mask (CV_8UC1, 255 where a dynamic box is the first hit).
void Render(const Scene& scene, const PinholeCamera& camera, const Rigid3d& world_from_cam,
            cv::Mat* depth, cv::Mat* dynamic_mask);

KeyframeData MakeKeyframe(int64_t id, const Scene& scene, const PinholeCamera& camera,
                          const Rigid3d& world_from_cam);

}  // namespace dygslam::box_room
