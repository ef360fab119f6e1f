// Maps of the shared Bonn frames with ground-truth poses (marker body pose * the dataset's
// marker-to-camera calibration), without any dynamic mask: the people walking through from
// frame ~110 on leave ghost cells in the map that a people-free reference observed as free.
#include <gtest/gtest.h>

#include <cstdio>
#include <vector>

#include "core/io/bonn.h"
#include "mapping/map_compare.h"
#include "mapping/octomap_builder.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {

struct BonnFrames {
  std::vector<KeyframeData> keyframes;  // world_from_cam = calibrated camera pose
  std::vector<Rigid3d> body_poses;      // raw ground truth
};

BonnFrames Load(const std::string& dir, int every) {
  BonnFrames frames;
  for (GroundTruthDepthFrame& f : LoadGroundTruthDepthFrames(dir, every)) {
    KeyframeData kf;
    kf.id = static_cast<int64_t>(f.index);
    kf.stamp = f.stamp;
    kf.depth = std::move(f.depth);
    kf.world_from_cam = f.world_from_body * BonnMarkerFromCam();
    frames.keyframes.push_back(std::move(kf));
    frames.body_poses.push_back(f.world_from_body);
  }
  return frames;
}

OctoMapOptions NoFilter() {
  OctoMapOptions options;
  options.use_dynamic_mask = false;
  return options;
}

TEST(BonnMap, PeopleLeaveGhostCellsWithoutAFilter) {
  DYGSLAM_REQUIRE_DATASET(dir, "bonn_crowd_part");
  const BonnFrames frames = Load(dir, 4);
  ASSERT_GE(frames.keyframes.size(), 85u);
  const PinholeCamera camera = BonnCamera();
  // Reference: people-free frames 0, 8, 16, ..., 96. Control: the other people-free frames
  // 4, 12, ..., 92 (same scene, different frames: the noise level of the measure).
  // Test: all frames 0..359 (every 4th).
  OctoMapBuilder reference(camera, NoFilter()), control(camera, NoFilter()),
      all(camera, NoFilter());
  for (const KeyframeData& kf : frames.keyframes) {
    if (kf.id < 100) (kf.id % 8 == 0 ? reference : control).Insert(kf);
    all.Insert(kf);
  }
  const GhostVoxelCounts noise = CompareGhostVoxels(control.tree(), reference.tree());
  const GhostVoxelCounts ghosts = CompareGhostVoxels(all.tree(), reference.tree());
  std::printf("control: %llu ghost of %llu occupied; all frames: %llu ghost of %llu occupied\n",
              static_cast<unsigned long long>(noise.ghost),
              static_cast<unsigned long long>(noise.occupied_in_a),
              static_cast<unsigned long long>(ghosts.ghost),
              static_cast<unsigned long long>(ghosts.occupied_in_a));
  // The static scene agrees: most of the control's cells are occupied in the reference too.
  EXPECT_GT(noise.occupied_a_occupied_b, noise.occupied_in_a * 6 / 10);
  // Ghosts proper (away from the reference's surfaces): next to none between two people-free
  // frame sets, many with the people in.
  EXPECT_LT(noise.GhostFraction(), 0.002);
  EXPECT_GT(ghosts.ghost, 10 * noise.ghost + 100);
  const OctoMapStats stats = all.Stats();
  EXPECT_EQ(stats.num_keyframes, frames.keyframes.size());
  EXPECT_GT(stats.memory_bytes, 100000u);
}

// The ground truth is the marker body pose; the camera pose needs the calibration. Without it
// the map smears: more occupied cells for the same static frames.
TEST(BonnMap, MarkerCalibrationSharpensTheMap) {
  DYGSLAM_REQUIRE_DATASET(dir, "bonn_crowd_part");
  const BonnFrames frames = Load(dir, 8);
  const PinholeCamera camera = BonnCamera();
  OctoMapBuilder calibrated(camera, NoFilter()), body(camera, NoFilter());
  for (size_t i = 0; i < frames.keyframes.size(); ++i) {
    if (frames.keyframes[i].id >= 100) break;
    KeyframeData kf = frames.keyframes[i];
    calibrated.Insert(kf);
    kf.world_from_cam = frames.body_poses[i];
    body.Insert(kf);
  }
  const OctoMapStats sharp = calibrated.Stats();
  const OctoMapStats smeared = body.Stats();
  std::printf("occupied cells frames 0-99: calibrated %llu, body pose %llu\n",
              static_cast<unsigned long long>(sharp.num_occupied_voxels),
              static_cast<unsigned long long>(smeared.num_occupied_voxels));
  EXPECT_LT(sharp.num_occupied_voxels * 10, smeared.num_occupied_voxels * 8);
  // And the calibrated camera is level-ish, looking slightly down, in a z-up world.
  const Eigen::Vector3d down =
      frames.keyframes[0].world_from_cam.rotation * Eigen::Vector3d::UnitY();
  EXPECT_LT(down.z(), -0.9);
}

}  // namespace
}  // namespace dygslam
