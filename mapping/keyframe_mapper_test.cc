#include "mapping/keyframe_mapper.h"

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <cmath>
#include <thread>
#include <vector>

#include "core/base/error.h"
#include "mapping/keyframe_consumer.h"
#include "mapping/map_compare.h"
#include "tools/synth/box_room.h"

namespace dygslam {
namespace {

using box_room::Box;
using box_room::LookingAlong;
using box_room::MakeKeyframe;
using box_room::Scene;

OctoMapOptions TestOptions() {
  OctoMapOptions options;
  options.pixel_stride = 1;
  options.resolution = 0.1;  // fast
  return options;
}

Rigid3d PoseOf(int k) {
  return LookingAlong({-1.0, 0.1 * std::sin(0.5 * k), 1.2}, 0.5 * std::sin(0.4 * k));
}

// A person walks in front of the camera in the first half.
KeyframeData Keyframe(int k) {
  Scene scene = box_room::DefaultRoom();
  if (k < 6)
    scene.dynamic_boxes.push_back(Box{{0.5, -0.5 + 0.2 * k, 0.0}, {0.9, -0.1 + 0.2 * k, 1.7}});
  return MakeKeyframe(k, scene, box_room::SmallCamera(), PoseOf(k));
}

// Same occupied and free cells.
void ExpectSameMap(const octomap::OcTree& a, const octomap::OcTree& b) {
  const GhostVoxelCounts ab = CompareGhostVoxels(a, b, 0), ba = CompareGhostVoxels(b, a, 0);
  EXPECT_GT(ab.occupied_in_a, 100u);
  EXPECT_EQ(ab.occupied_in_a, ab.occupied_in_b);
  EXPECT_EQ(ab.occupied_a_occupied_b, ab.occupied_in_a);
  EXPECT_EQ(ab.occupied_a_free_b + ab.occupied_a_unknown_b, 0u);
  EXPECT_EQ(ba.occupied_a_free_b + ba.occupied_a_unknown_b, 0u);
}

TEST(KeyframeMapper, AppliesInsertsCorrectionsAndRemovalsInOrder) {
  const PinholeCamera camera = box_room::SmallCamera();
  KeyframeMapper mapper(camera, TestOptions());
  KeyframeConsumer direct(camera, TestOptions());
  std::vector<KeyframeData> sequence;
  for (int k = 0; k < 12; ++k) sequence.push_back(Keyframe(k));
  // A local-BA style correction of keyframe 3 and the culling of keyframe 5.
  KeyframeData correction;
  correction.id = 3;
  correction.world_from_cam = PoseOf(3);
  correction.world_from_cam.translation.x() += 0.2;
  correction.pose_update_only = true;
  sequence.push_back(correction);
  KeyframeData culled;
  culled.id = 5;
  culled.removed = true;
  culled.pose_update_only = true;
  sequence.push_back(culled);

  for (const KeyframeData& k : sequence) {
    mapper.Submit(k);
    direct.Apply(k);
  }
  mapper.Flush();
  const MapperStats stats = mapper.Stats();
  EXPECT_EQ(stats.num_submitted, sequence.size());
  EXPECT_EQ(stats.num_applied, sequence.size());
  EXPECT_EQ(stats.num_new_keyframes, 12u);
  EXPECT_EQ(stats.num_pose_updates, 1u);
  EXPECT_EQ(stats.num_removals, 1u);
  mapper.WithBuilder([&](OctoMapBuilder& builder) {
    EXPECT_FALSE(builder.Contains(5));
    EXPECT_EQ(builder.KeyframeIds().size(), 11u);
    EXPECT_NEAR(builder.Pose(3).translation.x(), correction.world_from_cam.translation.x(), 1e-12);
    ExpectSameMap(builder.tree(), direct.builder().tree());
  });
}

TEST(KeyframeMapper, SubmitCopiesTheImages) {
  const PinholeCamera camera = box_room::SmallCamera();
  KeyframeMapper mapper(camera, TestOptions(), KeyframeMapperOptions{64});
  KeyframeConsumer direct(camera, TestOptions());
  for (int k = 0; k < 8; ++k) {
    KeyframeData keyframe = Keyframe(k);
    direct.Apply(keyframe);
    mapper.Submit(keyframe);
    // The caller reuses its buffers right away (as the SLAM does with the next frame).
    keyframe.depth.setTo(0.5f);
    keyframe.dynamic_mask.setTo(0);
  }
  mapper.Flush();
  mapper.WithBuilder(
      [&](OctoMapBuilder& builder) { ExpectSameMap(builder.tree(), direct.builder().tree()); });
}

TEST(KeyframeMapper, ConcurrentSubmittersAndBackPressureLoseNothing) {
  const PinholeCamera camera = box_room::SmallCamera();
  KeyframeMapper mapper(camera, TestOptions(), KeyframeMapperOptions{1});
  std::vector<KeyframeData> keyframes;
  for (int k = 0; k < 16; ++k) keyframes.push_back(Keyframe(k));
  // "Tracking" submits new keyframes; "local mapping" submits pose corrections of known ones.
  std::thread tracking([&] {
    for (const KeyframeData& k : keyframes) mapper.Submit(k);
  });
  std::thread local_mapping([&] {
    for (int i = 0; i < 40; ++i) {
      KeyframeData update;
      update.id = i % 16;
      update.world_from_cam = PoseOf(i % 16);
      update.pose_update_only = true;
      mapper.Submit(update);  // ignored if the keyframe is not in yet
    }
  });
  tracking.join();
  local_mapping.join();
  mapper.Flush();
  const MapperStats stats = mapper.Stats();
  EXPECT_EQ(stats.num_submitted, 56u);
  EXPECT_EQ(stats.num_applied + stats.num_coalesced, 56u);
  EXPECT_LE(stats.max_queue_depth, 1u);
  mapper.WithBuilder([&](OctoMapBuilder& builder) {
    EXPECT_EQ(builder.KeyframeIds().size(), 16u);
    for (int k = 0; k < 16; ++k)
      EXPECT_TRUE(builder.Pose(k).translation.isApprox(PoseOf(k).translation));
  });
}

// A pose correction is applied by a background rebuild when the mapper is idle (share 1: as
// soon as it is idle), not only when the map is read; with share 0 it waits for the read.
TEST(KeyframeMapper, BackgroundRebuildAppliesCorrections) {
  const PinholeCamera camera = box_room::SmallCamera();
  for (const double share : {1.0, 0.0}) {
    KeyframeMapperOptions mapper_options;
    mapper_options.max_rebuild_share = share;
    KeyframeMapper mapper(camera, TestOptions(), mapper_options);
    for (int k = 0; k < 4; ++k) mapper.Submit(Keyframe(k));
    KeyframeData correction;
    correction.id = 1;
    correction.world_from_cam = PoseOf(1);
    correction.world_from_cam.translation.y() += 0.3;
    correction.pose_update_only = true;
    mapper.Submit(correction);
    mapper.Flush();
    const MapperStats stats = mapper.Stats();
    mapper.WithBuilder([&](OctoMapBuilder& builder) {
      EXPECT_EQ(builder.rebuild_pending(), share == 0) << share;
      EXPECT_EQ(stats.num_background_rebuilds, share > 0 ? 1u : 0u) << share;
    });
  }
}

// Corrections of a keyframe whose earlier correction is still queued merge into it.
TEST(KeyframeMapper, QueuedCorrectionsOfAKeyframeCoalesce) {
  const PinholeCamera camera = box_room::SmallCamera();
  KeyframeMapper mapper(camera, TestOptions());
  auto correction = [](int id, double dx) {
    KeyframeData k;
    k.id = id;
    k.world_from_cam = PoseOf(id);
    k.world_from_cam.translation.x() += dx;
    k.pose_update_only = true;
    return k;
  };
  // Holding the builder keeps the worker from applying anything past the first item.
  mapper.WithBuilder([&](OctoMapBuilder&) {
    mapper.Submit(Keyframe(0));
    mapper.Submit(Keyframe(1));
    mapper.Submit(correction(0, 0.1));
    mapper.Submit(correction(0, 0.2));  // merges into the previous one
    mapper.Submit(correction(1, 0.1));
    mapper.Submit(correction(0, 0.3));  // merges again (keyframe 1's entry is another id)
    KeyframeData culled;
    culled.id = 1;
    culled.removed = true;
    culled.pose_update_only = true;
    mapper.Submit(culled);
    mapper.Submit(correction(1, 0.4));  // after the removal: not merged across it
  });
  mapper.Flush();
  const MapperStats stats = mapper.Stats();
  EXPECT_EQ(stats.num_submitted, 8u);
  EXPECT_EQ(stats.num_coalesced, 2u);
  EXPECT_EQ(stats.num_applied, 6u);
  mapper.WithBuilder([&](OctoMapBuilder& builder) {
    EXPECT_NEAR(builder.Pose(0).translation.x(), PoseOf(0).translation.x() + 0.3, 1e-12);
    EXPECT_FALSE(builder.Contains(1));
  });
}

TEST(KeyframeMapper, BadKeyframeSurfacesAtFlushNamingIt) {
  const PinholeCamera camera = box_room::SmallCamera();
  KeyframeMapper mapper(camera, TestOptions());
  KeyframeData bad = Keyframe(0);
  bad.id = 42;
  bad.depth = cv::Mat::zeros(10, 10, CV_32FC1);
  mapper.Submit(bad);
  try {
    mapper.Flush();
    ADD_FAILURE() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("keyframe 42"), std::string::npos) << e.what();
  }
  // The mapper keeps working afterwards.
  mapper.Submit(Keyframe(1));
  mapper.Flush();
  mapper.WithBuilder([](OctoMapBuilder& builder) { EXPECT_EQ(builder.KeyframeIds().size(), 1u); });
}

}  // namespace
}  // namespace dygslam
