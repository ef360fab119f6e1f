// MapperCore without DDS: generated keyframes (tools/synth box room) in, the map out as a
// MapUpdate message and as map.bt; corrections and removals of known keyframes are applied,
// unknown ids are ignored.
#include "components/mapper_core.h"

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <cmath>
#include <sstream>
#include <string>

#include "components/convert.h"
#include "mapping/map_compare.h"
#include "tests/support/test_support.h"
#include "tools/synth/box_room.h"

namespace dygslam {
namespace {

OctoMapOptions TestOctoMapOptions() {
  OctoMapOptions options;
  options.pixel_stride = 1;
  options.resolution = 0.1;  // fast
  return options;
}

KeyframeData Keyframe(int k) {
  const Rigid3d world_from_cam =
      box_room::LookingAlong({-1.0, 0.1 * std::sin(0.5 * k), 1.2}, 0.5 * std::sin(0.4 * k));
  return box_room::MakeKeyframe(k, box_room::DefaultRoom(), box_room::SmallCamera(),
                                world_from_cam);
}

std::unique_ptr<octomap::OcTree> TreeOf(const msg::MapUpdate& update) {
  std::stringstream stream(std::string(update.octree_bt().begin(), update.octree_bt().end()));
  auto tree = std::make_unique<octomap::OcTree>(update.resolution());
  EXPECT_TRUE(tree->readBinary(stream));
  return tree;
}

// Same occupied cells, none of them free or unknown in the other.
void ExpectSameOccupiedCells(const octomap::OcTree& a, const octomap::OcTree& b) {
  const GhostVoxelCounts ab = CompareGhostVoxels(a, b, 0);
  EXPECT_GT(ab.occupied_in_a, 100u);
  EXPECT_EQ(ab.occupied_in_a, ab.occupied_in_b);
  EXPECT_EQ(ab.occupied_a_occupied_b, ab.occupied_in_a);
}

TEST(MapperCore, BuildsTheMapTheBuilderBuildsAndPublishesIt) {
  const std::string tmp = testing::MakeTempDir("mapper_core");
  MapperOptions options;
  options.octomap = TestOctoMapOptions();
  options.map_path = tmp + "/map.bt";
  MapperCore core(options);
  EXPECT_FALSE(core.has_map());
  OctoMapBuilder reference(box_room::SmallCamera(), options.octomap);
  constexpr int kKeyframes = 6;
  for (int k = 0; k < kKeyframes; ++k) {
    core.Process(Keyframe(k), box_room::SmallCamera());
    reference.Insert(Keyframe(k));
  }
  ASSERT_TRUE(core.has_map());
  EXPECT_EQ(core.num_inserted(), static_cast<size_t>(kKeyframes));
  EXPECT_EQ(core.num_keyframes(), static_cast<size_t>(kKeyframes));

  const msg::MapUpdate update = core.MakeUpdate();
  EXPECT_EQ(update.num_keyframes(), static_cast<uint64_t>(kKeyframes));
  EXPECT_EQ(update.header().seq(), static_cast<uint64_t>(kKeyframes));
  EXPECT_EQ(TimeFromMsg(update.header().stamp(), "stamp"), Keyframe(kKeyframes - 1).stamp);
  EXPECT_DOUBLE_EQ(update.resolution(), options.octomap.resolution);
  EXPECT_GT(update.num_occupied(), 0u);
  ExpectSameOccupiedCells(*TreeOf(update), reference.tree());

  core.Write();
  const std::unique_ptr<octomap::OcTree> written = ReadOctoMap(options.map_path);
  ExpectSameOccupiedCells(*written, reference.tree());
}

TEST(MapperCore, AppliesCorrectionsAndRemovalsOfKnownKeyframesOnly) {
  MapperOptions options;
  options.octomap = TestOctoMapOptions();
  options.map_path = "";
  MapperCore core(options);
  for (int k = 0; k < 4; ++k) core.Process(Keyframe(k), box_room::SmallCamera());

  KeyframeData correction;
  correction.id = 2;
  correction.pose_update_only = true;
  correction.world_from_cam = Keyframe(3).world_from_cam;
  core.Process(correction, box_room::SmallCamera());
  EXPECT_EQ(core.num_pose_updates(), 1u);

  KeyframeData unknown = correction;
  unknown.id = 99;
  core.Process(unknown, box_room::SmallCamera());
  EXPECT_EQ(core.num_pose_updates(), 1u) << "a correction of an unknown keyframe is ignored";

  KeyframeData culled;
  culled.id = 1;
  culled.removed = true;
  core.Process(culled, box_room::SmallCamera());
  EXPECT_EQ(core.num_removed(), 1u);
  EXPECT_EQ(core.num_keyframes(), 3u);
  culled.id = 99;
  core.Process(culled, box_room::SmallCamera());
  EXPECT_EQ(core.num_removed(), 1u) << "a removal of an unknown keyframe is ignored";
  EXPECT_EQ(core.MakeUpdate().num_keyframes(), uint64_t{3});
  EXPECT_EQ(core.num_inserted(), 4u);
}

TEST(MapperCore, BadOptionsAreRefusedByName) {
  MapperOptions options;
  options.max_update_share = 0;
  try {
    MapperCore core(options);
    FAIL() << "max_update_share = 0 accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("mapper.max_update_share"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace dygslam
