#include "mapping/map_frame.h"

#include <gtest/gtest.h>

#include <cmath>

#include "mapping/octomap_builder.h"
#include "tools/synth/box_room.h"

namespace dygslam {
namespace {

// The default room (floor at z = 0, camera at 1.2 m) mapped in a tilted, shifted world, as a
// SLAM whose world is the first camera frame would: the floor is found and the level frame
// undoes the tilt.
TEST(MapFrame, FindsTheFloorAndLevelsTheMap) {
  const Rigid3d tilted_from_room(
      Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 0.4, 0).normalized())),
      Eigen::Vector3d(0.7, -2.0, 0.4));
  const PinholeCamera camera = box_room::SmallCamera();
  OctoMapOptions options;
  options.pixel_stride = 1;
  OctoMapBuilder builder(camera, options);
  const box_room::Scene scene = box_room::DefaultRoom();
  Rigid3d first;
  for (int k = 0; k < 10; ++k) {
    // Looking a little down, so the floor is in view.
    Rigid3d pose = box_room::LookingAlong({-1.0, 0.2 * std::sin(k), 1.2}, 0.6 * k - 2.7);
    pose.rotation =
        pose.rotation * Eigen::Quaterniond(Eigen::AngleAxisd(-0.35, Eigen::Vector3d::UnitX()));
    KeyframeData keyframe = box_room::MakeKeyframe(k, scene, camera, pose);
    keyframe.world_from_cam = tilted_from_room * pose;
    if (k == 0) first = keyframe.world_from_cam;
    builder.Insert(keyframe);
  }
  // Prior: "up" in the first image, 20 degrees off the true up (the camera looks down).
  const Eigen::Vector3d prior_up = first.rotation * -Eigen::Vector3d::UnitY();
  const Eigen::Vector3d true_up = tilted_from_room.rotation * Eigen::Vector3d::UnitZ();
  EXPECT_GT(std::acos(prior_up.dot(true_up)), 0.3);
  const FloorEstimate floor = EstimateFloor(builder.tree(), prior_up, first.translation);
  ASSERT_TRUE(floor.found);
  EXPECT_GT(floor.up.dot(true_up), std::cos(2.0 * M_PI / 180));
  // Floor at room z = 0: offset = up . (tilted_from_room * 0) within a cell.
  EXPECT_NEAR(floor.offset, true_up.dot(tilted_from_room.translation), options.resolution);

  const Rigid3d level_from_world = LevelFrameFromWorld(floor, prior_up, first);
  const Rigid3d level_first = level_from_world * first;
  EXPECT_NEAR(level_first.translation.x(), 0.0, 1e-9);
  EXPECT_NEAR(level_first.translation.y(), 0.0, 1e-9);
  EXPECT_NEAR(level_first.translation.z(), 1.2,
              options.resolution);  // camera height above the floor
  const Eigen::Vector3d forward = level_first.rotation * Eigen::Vector3d::UnitZ();
  EXPECT_GT(forward.y(), 0.8);
  EXPECT_NEAR(forward.x(), 0.0, 1e-9);
}

TEST(MapFrame, NoFloorInAnEmptyMap) {
  octomap::OcTree empty(0.05);
  const FloorEstimate floor =
      EstimateFloor(empty, Eigen::Vector3d::UnitZ(), Eigen::Vector3d::Zero());
  EXPECT_FALSE(floor.found);
  const Rigid3d cam(Eigen::Quaterniond::Identity(), Eigen::Vector3d(1, 2, 3));
  const Rigid3d level = LevelFrameFromWorld(floor, -Eigen::Vector3d::UnitY(), cam);
  EXPECT_TRUE((level * cam).translation.isZero(1e-9));
}

}  // namespace
}  // namespace dygslam
