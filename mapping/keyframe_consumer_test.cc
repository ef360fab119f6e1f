// KeyframeConsumer: the one place a keyframe stream (new / pose update / removed) reaches the map.
#include "mapping/keyframe_consumer.h"

#include <gtest/gtest.h>

#include "core/base/error.h"
#include "tools/synth/box_room.h"

namespace dygslam {
namespace {

OctoMapOptions CoarseOptions() {
  OctoMapOptions options;
  options.pixel_stride = 2;
  options.resolution = 0.1;  // fast
  return options;
}

Rigid3d WalkPose(int k) { return box_room::LookingAlong({-1.0 + 0.1 * k, 0.0, 1.2}, 0.0); }

KeyframeData Keyframe(int k) {
  return box_room::MakeKeyframe(k, box_room::DefaultRoom(), box_room::SmallCamera(), WalkPose(k));
}

KeyframeData PoseUpdate(int id, const Rigid3d& pose) {
  KeyframeData update;
  update.id = id;
  update.world_from_cam = pose;
  update.pose_update_only = true;
  return update;
}

KeyframeData Removal(int id) {
  KeyframeData culled;
  culled.id = id;
  culled.removed = true;
  culled.pose_update_only = true;  // as the SLAM emits it: removal wins
  return culled;
}

TEST(KeyframeConsumer, ChangeOfAMessage) {
  EXPECT_EQ(ChangeOf(Keyframe(0)), KeyframeChange::kNew);
  EXPECT_EQ(ChangeOf(PoseUpdate(0, WalkPose(0))), KeyframeChange::kPoseUpdate);
  EXPECT_EQ(ChangeOf(Removal(0)), KeyframeChange::kRemoved);
  EXPECT_STREQ(ToString(KeyframeChange::kPoseUpdate), "pose update");
}

TEST(KeyframeConsumer, AppliesEachKindToTheBuilder) {
  KeyframeConsumer consumer(box_room::SmallCamera(), CoarseOptions());
  for (int k = 0; k < 3; ++k) {
    const KeyframeApplied a = consumer.Apply(Keyframe(k));
    EXPECT_EQ(a.change, KeyframeChange::kNew);
    EXPECT_TRUE(a.applied);
  }
  EXPECT_EQ(consumer.builder().KeyframeIds().size(), 3u);
  EXPECT_GT(consumer.builder().Stats().num_occupied_leaves, 0u);

  // A correction moves the stored pose (30 cm: the tree is to be rebuilt).
  Rigid3d moved = WalkPose(1);
  moved.translation.x() += 0.3;
  KeyframeApplied a = consumer.Apply(PoseUpdate(1, moved));
  EXPECT_EQ(a.change, KeyframeChange::kPoseUpdate);
  EXPECT_TRUE(a.applied);
  EXPECT_NEAR(consumer.builder().Pose(1).translation.x(), moved.translation.x(), 1e-12);
  EXPECT_TRUE(consumer.builder().rebuild_pending());

  // Culling takes the keyframe out; the same removal again changes nothing.
  a = consumer.Apply(Removal(2));
  EXPECT_EQ(a.change, KeyframeChange::kRemoved);
  EXPECT_TRUE(a.applied);
  EXPECT_FALSE(consumer.builder().Contains(2));
  EXPECT_FALSE(consumer.Apply(Removal(2)).applied);

  // Updates of keyframes the map does not hold are ignored, not counted.
  EXPECT_FALSE(consumer.Apply(PoseUpdate(42, moved)).applied);
  EXPECT_EQ(consumer.num_inserted(), 3u);
  EXPECT_EQ(consumer.num_pose_updates(), 1u);
  EXPECT_EQ(consumer.num_removed(), 1u);
  EXPECT_EQ(consumer.builder().KeyframeIds(), (std::vector<int64_t>{0, 1}));
}

TEST(KeyframeConsumer, BadKeyframeIsAnErrorNamingIt) {
  KeyframeConsumer consumer(box_room::SmallCamera(), CoarseOptions());
  KeyframeData bad = Keyframe(7);
  bad.depth = cv::Mat(bad.depth.rows, bad.depth.cols, CV_16UC1, cv::Scalar(1000));
  try {
    consumer.Apply(bad);
    ADD_FAILURE() << "a CV_16UC1 keyframe depth was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("keyframe 7"), std::string::npos) << e.what();
  }
  EXPECT_EQ(consumer.num_inserted(), 0u);
  EXPECT_TRUE(consumer.builder().KeyframeIds().empty());
}

}  // namespace
}  // namespace dygslam
