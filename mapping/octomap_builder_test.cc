#include "mapping/octomap_builder.h"

#include <gtest/gtest.h>
#include <octomap/AbstractOcTree.h>
#include <octomap/OcTree.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <utility>

#include "core/base/error.h"
#include "mapping/map_compare.h"
#include "tests/support/test_support.h"
#include "tools/synth/box_room.h"

namespace dygslam {
namespace {

using box_room::Box;
using box_room::LookingAlong;
using box_room::MakeKeyframe;
using box_room::Scene;

constexpr int kWalkFrames = 40;  // the person walks across the room
constexpr int kAfterFrames = 6;  // then the camera keeps looking at the empty path

// Person-sized box walking along y in front of the far wall, then gone.
Box PersonAt(int frame) {
  const double y = -0.7 + 0.035 * frame;  // stays in view
  return {{0.31, y - 0.2, -0.02}, {0.71, y + 0.2, 1.68}};
}

// Volume swept by the person, without the floor cells.
bool OnPath(const octomap::point3d& c) {
  return c.x() > 0.31 && c.x() < 0.71 && c.y() > -1.4 && c.y() < 1.4 && c.z() > 0.15 &&
         c.z() < 1.68;
}

Rigid3d WalkPose(int frame) {
  return LookingAlong({-1.2, 0.05 * std::sin(0.2 * frame), 1.2}, 0.15 * std::sin(0.3 * frame));
}

OctoMapOptions TestOptions() {
  OctoMapOptions options;
  options.pixel_stride = 1;  // the test camera is small already
  return options;
}

// Inserts the walking-person sequence.
void InsertWalk(OctoMapBuilder* builder) {
  const PinholeCamera camera = box_room::SmallCamera();
  for (int k = 0; k < kWalkFrames + kAfterFrames; ++k) {
    Scene scene = box_room::DefaultRoom();
    if (k < kWalkFrames) scene.dynamic_boxes.push_back(PersonAt(k));
    builder->Insert(MakeKeyframe(k, scene, camera, WalkPose(k)));
  }
}

// Within `margin` of a static surface of the default room.
bool NearStaticSurface(const octomap::point3d& c, double margin) {
  const Scene scene = box_room::DefaultRoom();
  const Eigen::Vector3d p(c.x(), c.y(), c.z());
  for (int a = 0; a < 3; ++a) {
    if (std::abs(p[a] - scene.room.min[a]) < margin || std::abs(p[a] - scene.room.max[a]) < margin)
      return true;
  }
  for (const Box& box : scene.static_boxes) {
    if (box.Contains(p, margin)) return true;
  }
  return false;
}

TEST(OctoMapOptions, CheckNamesTheField) {
  OctoMapOptions options;
  EXPECT_NO_THROW(options.Check());
  options.resolution = 0;
  try {
    options.Check();
    FAIL() << "expected InvalidOptions";
  } catch (const InvalidOptions& e) {
    EXPECT_NE(std::string(e.what()).find("OctoMap.resolution"), std::string::npos) << e.what();
  }
  options = OctoMapOptions();
  options.prob_miss = 0.6;
  EXPECT_THROW(options.Check(), InvalidOptions);
  options = OctoMapOptions();
  options.min_range = 5.0;  // beyond max_range
  EXPECT_THROW(options.Check(), InvalidOptions);
  EXPECT_THROW(OctoMapBuilder(PinholeCamera(), OctoMapOptions()), InvalidOptions);  // fx = 0
}

TEST(OctoMapBuilder, RejectsMalformedKeyframes) {
  const PinholeCamera camera = box_room::SmallCamera();
  OctoMapBuilder builder(camera, TestOptions());
  KeyframeData keyframe =
      MakeKeyframe(7, box_room::DefaultRoom(), camera, LookingAlong({0, 0, 1}, 0));
  KeyframeData wrong_type = keyframe;
  wrong_type.depth.convertTo(wrong_type.depth, CV_16UC1, 5000.0);
  try {
    builder.Insert(wrong_type);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("keyframe 7"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("depth"), std::string::npos) << e.what();
  }
  KeyframeData wrong_size = keyframe;
  wrong_size.depth = cv::Mat::zeros(10, 10, CV_32FC1);
  EXPECT_THROW(builder.Insert(wrong_size), InputError);
  KeyframeData wrong_mask = keyframe;
  wrong_mask.dynamic_mask = cv::Mat::zeros(10, 10, CV_8UC1);
  EXPECT_THROW(builder.Insert(wrong_mask), InputError);
  KeyframeData wrong_flags = keyframe;
  wrong_flags.keypoints.resize(3);
  wrong_flags.keypoint_dynamic.assign(2, 1);
  EXPECT_THROW(builder.Insert(wrong_flags), InputError);
  KeyframeData bad_pose = keyframe;
  bad_pose.world_from_cam.translation.x() = std::nan("");
  EXPECT_THROW(builder.Insert(bad_pose), InputError);
  EXPECT_EQ(builder.Stats().num_keyframes, 0u);
}

TEST(OctoMapBuilder, ExtractLeavesOutMaskAndDynamicKeypoints) {
  const PinholeCamera camera = box_room::SmallCamera();
  Scene scene = box_room::DefaultRoom();
  scene.dynamic_boxes.push_back(PersonAt(20));
  KeyframeData keyframe = MakeKeyframe(1, scene, camera, WalkPose(20));
  const int mask_pixels = cv::countNonZero(keyframe.dynamic_mask);
  ASSERT_GT(mask_pixels, 500);

  OctoMapOptions options = TestOptions();
  options.use_voxel_filter = false;
  options.dynamic_mask_dilation_px = 0;
  OctoMapBuilder builder(camera, options);
  const StaticCloud masked = builder.ExtractStaticCloud(keyframe);
  EXPECT_EQ(masked.num_dynamic_pixels, static_cast<size_t>(mask_pixels));
  EXPECT_EQ(masked.points_cam.size(), masked.num_valid_pixels - mask_pixels);

  // Dilation grows the left-out area.
  options.dynamic_mask_dilation_px = 4;
  EXPECT_GT(OctoMapBuilder(camera, options).ExtractStaticCloud(keyframe).num_dynamic_pixels,
            static_cast<size_t>(mask_pixels));

  // No mask, one keypoint in the middle of the person flagged dynamic: a disk goes.
  KeyframeData by_keypoint = keyframe;
  by_keypoint.dynamic_mask.release();
  cv::Moments m = cv::moments(keyframe.dynamic_mask, true);
  by_keypoint.keypoints.emplace_back(cv::Point2f(m.m10 / m.m00, m.m01 / m.m00), 7.f);
  by_keypoint.keypoints.emplace_back(cv::Point2f(5, 5), 7.f);
  by_keypoint.keypoint_dynamic = {1, 0};
  options.dynamic_keypoint_radius_px = 6;
  const StaticCloud by_flags = OctoMapBuilder(camera, options).ExtractStaticCloud(by_keypoint);
  EXPECT_GT(by_flags.num_dynamic_pixels, 100u);  // ~pi * 6^2
  EXPECT_LT(by_flags.num_dynamic_pixels, 150u);
  by_keypoint.keypoint_dynamic = {0, 0};
  EXPECT_EQ(OctoMapBuilder(camera, options).ExtractStaticCloud(by_keypoint).num_dynamic_pixels, 0u);

  // use_dynamic_mask = false: everything goes in.
  options.use_dynamic_mask = false;
  EXPECT_EQ(OctoMapBuilder(camera, options).ExtractStaticCloud(keyframe).num_dynamic_pixels, 0u);

  // The voxel filter keeps at most one point per 5 cm cell.
  options = TestOptions();
  const StaticCloud filtered = OctoMapBuilder(camera, options).ExtractStaticCloud(keyframe);
  EXPECT_LT(filtered.points_cam.size(), masked.points_cam.size() / 2);
  EXPECT_GT(filtered.points_cam.size(), 100u);
}

// (1) walls and furniture are occupied, nothing else is; (3) free space between camera and
// wall is cleared; space behind the wall is unknown.
TEST(OctoMapBuilder, StaticStructureOccupiedAndFreeSpaceCleared) {
  OctoMapBuilder builder(box_room::SmallCamera(), TestOptions());
  InsertWalk(&builder);
  const octomap::OcTree& tree = builder.tree();

  int wall_cells = 0, wall_occupied = 0;
  for (double y = -0.9; y <= 0.9; y += 0.1) {
    for (double z = 0.5; z <= 2.0; z += 0.1) {
      ++wall_cells;
      wall_occupied += CellState(tree, octomap::point3d(2.52, y, z)) == 1;
    }
  }
  EXPECT_EQ(wall_occupied, wall_cells);
  EXPECT_EQ(CellState(tree, octomap::point3d(1.52, -1.25, 0.5)), 1);  // cabinet front
  EXPECT_EQ(CellState(tree, octomap::point3d(1.5, 0.3, -0.01)), 1);   // floor
  const Box cabinet = box_room::DefaultRoom().static_boxes[0];
  EXPECT_GT(CountOccupiedInside(tree,
                                [&](const octomap::point3d& c) {
                                  return cabinet.Contains(Eigen::Vector3d(c.x(), c.y(), c.z()),
                                                          0.03);
                                }),
            30u);

  EXPECT_EQ(CellState(tree, octomap::point3d(-0.5, 0.0, 1.2)), 0);  // between camera and wall
  EXPECT_EQ(CellState(tree, octomap::point3d(2.0, 0.3, 1.6)), 0);
  EXPECT_EQ(CellState(tree, octomap::point3d(3.0, 0.0, 1.2)), -1);  // behind the wall

  const uint64_t stray = CountOccupiedInside(
      tree, [](const octomap::point3d& c) { return !NearStaticSurface(c, 0.08); });
  EXPECT_EQ(stray, 0u);

  const OctoMapStats stats = builder.Stats();
  EXPECT_EQ(stats.num_keyframes, static_cast<size_t>(kWalkFrames + kAfterFrames));
  EXPECT_GT(stats.num_occupied_leaves, 500u);
  EXPECT_GT(stats.num_free_leaves, 100u);
  EXPECT_GE(stats.num_occupied_voxels, stats.num_occupied_leaves);
  EXPECT_GT(stats.num_free_voxels, stats.num_free_leaves);  // free space prunes into big leaves
  // The counts agree with the tree itself, not only "something ran".
  EXPECT_EQ(stats.memory_bytes, tree.memoryUsage());
  EXPECT_EQ(stats.num_leaves, tree.getNumLeafNodes());
  EXPECT_EQ(stats.num_occupied_leaves + stats.num_free_leaves, stats.num_leaves);
  EXPECT_EQ(stats.num_insertions, static_cast<size_t>(kWalkFrames + kAfterFrames));
  EXPECT_GT(stats.num_stored_points, stats.num_occupied_leaves);
  // Times are a median over the insertions: finite, positive and the CPU time of the inserting
  // thread cannot exceed the wall time by more than clock granularity.
  EXPECT_TRUE(std::isfinite(stats.median_insert_ms));
  EXPECT_GT(stats.median_insert_ms, 0.0);
  EXPECT_LE(stats.median_insert_cpu_ms, stats.median_insert_ms * 1.05 + 0.5);
  EXPECT_EQ(stats.num_rebuilds, 0u);
}

// (2) with the dynamic mask no cell on the person's path is occupied once it has left; with the
// mask ignored the person leaves ghost cells (so this test can fail).
TEST(OctoMapBuilder, DynamicMaskKeepsThePersonOut) {
  OctoMapBuilder masked(box_room::SmallCamera(), TestOptions());
  InsertWalk(&masked);
  EXPECT_EQ(CountOccupiedInside(masked.tree(), OnPath), 0u);

  OctoMapOptions options = TestOptions();
  options.use_dynamic_mask = false;
  OctoMapBuilder unmasked(box_room::SmallCamera(), options);
  InsertWalk(&unmasked);
  EXPECT_GT(CountOccupiedInside(unmasked.tree(), OnPath), 20u);
}

// (4) .bt and .ot round-trip, atomically written, readable by OctoMap itself.
TEST(OctoMapBuilder, BinaryAndFullFilesRoundTrip) {
  OctoMapBuilder builder(box_room::SmallCamera(), TestOptions());
  InsertWalk(&builder);
  const std::string dir = testing::MakeTempDir("octomap_io");
  const std::string bt = dir + "/map.bt";
  const std::string ot = dir + "/map.ot";
  builder.WriteBinary(bt);
  builder.WriteFull(ot);
  const octomap::OcTree& tree = builder.tree();

  // With OctoMap's own readers.
  octomap::OcTree from_bt(bt);
  EXPECT_EQ(from_bt.getResolution(), tree.getResolution());
  std::unique_ptr<octomap::AbstractOcTree> from_ot(octomap::AbstractOcTree::read(ot));
  ASSERT_NE(from_ot, nullptr);
  auto* ot_tree = dynamic_cast<octomap::OcTree*>(from_ot.get());
  ASSERT_NE(ot_tree, nullptr);

  // Same occupied cells, no cell changes state. .ot keeps the probabilities exactly.
  for (const octomap::OcTree* loaded : std::vector<const octomap::OcTree*>{&from_bt, ot_tree}) {
    const GhostVoxelCounts c = CompareGhostVoxels(tree, *loaded);
    EXPECT_EQ(c.occupied_in_a, c.occupied_in_b);
    EXPECT_EQ(c.occupied_a_occupied_b, c.occupied_in_a);
    EXPECT_EQ(c.occupied_b_free_a, 0u);
  }
  EXPECT_EQ(ot_tree->size(), tree.size());
  int checked = 0;
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end && checked < 2000; ++it) {
    const octomap::OcTreeNode* node = ot_tree->search(it.getKey(), it.getDepth());
    ASSERT_NE(node, nullptr);
    EXPECT_FLOAT_EQ(node->getLogOdds(), it->getLogOdds());
    ++checked;
  }

  // With ReadOctoMap (format from the header).
  EXPECT_EQ(ReadOctoMap(bt)->size(), from_bt.size());
  EXPECT_EQ(ReadOctoMap(ot)->size(), tree.size());

  // No temporary files left behind; bad files are named in the error.
  for (const auto& entry : std::filesystem::directory_iterator(dir))
    EXPECT_EQ(entry.path().filename().string().find(".tmp."), std::string::npos) << entry.path();
  const std::string garbage = dir + "/garbage.bt";
  std::ofstream(garbage) << "not an octomap\n";
  try {
    ReadOctoMap(garbage);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("garbage.bt"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ReadOctoMap(dir + "/missing.bt"), InputError);
  EXPECT_THROW(builder.WriteBinary(dir + "/no_such_dir/map.bt"), InputError);
}

// A map continued from a saved .ot (first half of the walk) and the second half
// inserted on top is the map of the whole walk; a rebuild starts from the loaded map again; a map
// of another resolution is refused naming the file.
TEST(OctoMapBuilder, ContinuesASavedMap) {
  const PinholeCamera camera = box_room::SmallCamera();
  constexpr int kHalf = (kWalkFrames + kAfterFrames) / 2;
  auto keyframe = [&](int k) {
    Scene scene = box_room::DefaultRoom();
    if (k < kWalkFrames) scene.dynamic_boxes.push_back(PersonAt(k));
    return MakeKeyframe(k, scene, camera, WalkPose(k));
  };
  OctoMapBuilder whole(camera, TestOptions()), first(camera, TestOptions());
  for (int k = 0; k < kWalkFrames + kAfterFrames; ++k) whole.Insert(keyframe(k));
  for (int k = 0; k < kHalf; ++k) first.Insert(keyframe(k));
  const std::string dir = testing::MakeTempDir("octomap_continue");
  first.WriteFull(dir + "/first.ot");

  OctoMapBuilder continued(camera, TestOptions());
  continued.SetBaseMap(*ReadOctoMap(dir + "/first.ot"), dir + "/first.ot");
  EXPECT_TRUE(continued.has_base_map());
  EXPECT_EQ(continued.tree().size(), first.tree().size());
  for (int k = kHalf; k < kWalkFrames + kAfterFrames; ++k) continued.Insert(keyframe(k));
  const GhostVoxelCounts c = CompareGhostVoxels(whole.tree(), continued.tree());
  EXPECT_GT(c.occupied_in_a, 100u);
  EXPECT_EQ(c.occupied_in_a, c.occupied_in_b);
  EXPECT_EQ(c.occupied_a_occupied_b, c.occupied_in_a);

  // Removing every inserted keyframe (a rebuild) leaves the loaded map.
  for (int k = kHalf; k < kWalkFrames + kAfterFrames; ++k) continued.Remove(k);
  const GhostVoxelCounts back = CompareGhostVoxels(first.tree(), continued.tree());
  EXPECT_EQ(back.occupied_in_a, back.occupied_in_b);
  EXPECT_EQ(back.occupied_a_occupied_b, back.occupied_in_a);

  OctoMapOptions coarse = TestOptions();
  coarse.resolution = 2 * coarse.resolution;
  OctoMapBuilder other(camera, coarse);
  try {
    other.SetBaseMap(*ReadOctoMap(dir + "/first.ot"), dir + "/first.ot");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("first.ot"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("resolution"), std::string::npos) << e.what();
  }
}

// (5) Pose corrections move the map; small ones do not trigger a rebuild.
TEST(OctoMapBuilder, UpdatePosesMovesTheMap) {
  const PinholeCamera camera = box_room::SmallCamera();
  OctoMapBuilder builder(camera, TestOptions());
  const Scene scene = box_room::DefaultRoom();
  for (int k = 0; k < 4; ++k) builder.Insert(MakeKeyframe(k, scene, camera, WalkPose(k)));
  const octomap::point3d wall(2.52, 0.1, 1.2), shifted_wall(2.22, 0.1, 1.2);
  EXPECT_EQ(CellState(builder.tree(), wall), 1);
  EXPECT_EQ(CellState(builder.tree(), shifted_wall), 0);

  // 1 mm: far below half a voxel at max_range; the tree is not rebuilt.
  std::map<int64_t, Rigid3d> nudged;
  for (int k = 0; k < 4; ++k) {
    Rigid3d pose = WalkPose(k);
    pose.translation.x() -= 0.001;
    nudged[k] = pose;
  }
  nudged[99] = Rigid3d();  // unknown id: ignored
  EXPECT_EQ(builder.UpdatePoses(nudged), 4u);
  EXPECT_FALSE(builder.rebuild_pending());

  // The map's keyframes drift 30 cm back: the wall moves with them.
  std::map<int64_t, Rigid3d> corrected;
  for (int k = 0; k < 4; ++k) {
    Rigid3d pose = WalkPose(k);
    pose.translation.x() -= 0.30;
    corrected[k] = pose;
  }
  builder.UpdatePoses(corrected);
  EXPECT_TRUE(builder.rebuild_pending());
  EXPECT_EQ(CellState(builder.tree(), shifted_wall), 1);
  EXPECT_NE(CellState(builder.tree(), wall), 1);
  EXPECT_EQ(builder.Stats().num_rebuilds, 1u);
  EXPECT_NEAR(builder.Pose(2).translation.x(), WalkPose(2).translation.x() - 0.30, 1e-12);

  // A rotation of 1 degree moves points at 4 m by 7 cm: rebuild.
  std::map<int64_t, Rigid3d> rotated = corrected;
  rotated[0].rotation =
      Eigen::AngleAxisd(M_PI / 180, Eigen::Vector3d::UnitZ()) * rotated[0].rotation;
  builder.UpdatePoses(rotated);
  EXPECT_TRUE(builder.rebuild_pending());

  // A pose_update_only or removed keyframe is not one to insert (KeyframeConsumer applies them):
  // an error naming the keyframe, and the map is unchanged.
  KeyframeData update;
  update.id = 1;
  update.world_from_cam = WalkPose(1);
  update.pose_update_only = true;
  EXPECT_THROW(builder.Insert(update), InputError);
  update.pose_update_only = false;
  update.removed = true;
  try {
    builder.Insert(update);
    ADD_FAILURE() << "a removed keyframe was inserted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("keyframe 1"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(builder.Contains(1));
  EXPECT_NE(builder.Pose(1).translation, WalkPose(1).translation);
}

// Finalize: the tree is the one of the final poses, whichever rebuilds ran before. Builder a is
// rebuilt after keyframe 1 and nudged by corrections below the rebuild threshold afterwards; b
// inserts the keyframes at their final poses: after Finalize both write the same bytes, and
// without it they differ (the nudges are not in a's tree).
TEST(OctoMapBuilder, FinalizeGivesTheMapOfTheFinalPoses) {
  const PinholeCamera camera = box_room::SmallCamera();
  const Scene scene = box_room::DefaultRoom();
  auto nudged = [](int k) {
    Rigid3d pose = WalkPose(k);
    pose.translation.x() -= 0.004 * (k + 1);  // below half a voxel at max_range
    return pose;
  };
  OctoMapBuilder a(camera, TestOptions()), b(camera, TestOptions());
  for (int k = 0; k < 6; ++k) {
    a.Insert(MakeKeyframe(k, scene, camera, WalkPose(k)));
    if (k == 1) {
      Rigid3d far = WalkPose(0);
      far.translation.x() -= 0.3;
      a.UpdatePoses({{0, far}});
      a.Sync();  // a rebuild during the run
      a.UpdatePoses({{0, WalkPose(0)}});
      a.Sync();
    }
  }
  std::map<int64_t, Rigid3d> final_poses;
  for (int k = 0; k < 6; ++k) final_poses[k] = nudged(k);
  a.UpdatePoses(final_poses);
  EXPECT_FALSE(a.rebuild_pending());
  for (int k = 0; k < 6; ++k) {  // the same images, inserted at the final poses
    KeyframeData keyframe = MakeKeyframe(k, scene, camera, WalkPose(k));
    keyframe.world_from_cam = nudged(k);
    b.Insert(keyframe);
  }
  auto bytes = [](OctoMapBuilder& builder) {
    std::ostringstream out;
    WriteOctoMapBinaryStream(builder.tree(), out);
    return out.str();
  };
  EXPECT_TRUE(bytes(a) != bytes(b));
  a.Finalize();
  b.Finalize();
  EXPECT_TRUE(bytes(a) == bytes(b));
  EXPECT_EQ(a.Stats().num_rebuilds, 3u);
  const size_t before = b.Stats().num_rebuilds;
  b.Finalize();  // nothing moved since: no rebuild
  EXPECT_EQ(b.Stats().num_rebuilds, before);
}

// Culled keyframes leave the map.
TEST(OctoMapBuilder, RemoveTakesAKeyframeOut) {
  const PinholeCamera camera = box_room::SmallCamera();
  OctoMapBuilder builder(camera, TestOptions());
  Scene with_crate = box_room::DefaultRoom();
  const Box crate{{0.31, -0.39, -0.02}, {0.71, 0.41, 0.68}};
  with_crate.static_boxes.push_back(crate);
  const auto in_crate = [&](const octomap::point3d& c) {
    return crate.Contains(Eigen::Vector3d(c.x(), c.y(), c.z())) && c.z() > 0.1;
  };
  builder.Insert(MakeKeyframe(10, with_crate, camera, WalkPose(0)));
  EXPECT_GT(CountOccupiedInside(builder.tree(), in_crate), 20u);
  builder.Insert(MakeKeyframe(11, box_room::DefaultRoom(), camera, WalkPose(1)));
  EXPECT_TRUE(builder.Remove(10));
  EXPECT_FALSE(builder.Remove(10));
  EXPECT_FALSE(builder.Contains(10));
  EXPECT_EQ(CountOccupiedInside(builder.tree(), in_crate), 0u);
  EXPECT_EQ(CellState(builder.tree(), octomap::point3d(2.52, 0.1, 1.2)), 1);
  EXPECT_EQ(builder.KeyframeIds(), std::vector<int64_t>{11});
  EXPECT_TRUE(builder.Remove(11));
  EXPECT_EQ(builder.tree().size(), 0u);
}

// The .bt stream is OctoMap's own bytes, written without the library's progress line on stderr
// ("Writing N nodes to output stream... done." for every write of a running mapper).
// A keyframe whose static cloud was extracted ahead (ExtractStaticCloud, images released after)
// gives the same map, byte for byte, as the keyframe inserted with its images.
TEST(OctoMapBuilder, CloudExtractedAheadGivesTheSameMap) {
  const PinholeCamera camera = box_room::SmallCamera();
  OctoMapBuilder direct(camera, TestOptions());
  InsertWalk(&direct);
  OctoMapBuilder ahead(camera, TestOptions());
  for (int k = 0; k < kWalkFrames + kAfterFrames; ++k) {
    Scene scene = box_room::DefaultRoom();
    if (k < kWalkFrames) scene.dynamic_boxes.push_back(PersonAt(k));
    KeyframeData keyframe = MakeKeyframe(k, scene, camera, WalkPose(k));
    StaticCloud cloud = ExtractStaticCloud(keyframe, camera, TestOptions());
    keyframe.rgb.release();
    keyframe.depth.release();
    keyframe.dynamic_mask.release();
    ahead.Insert(keyframe, std::move(cloud));
  }
  EXPECT_EQ(ahead.Stats().num_keyframes, static_cast<size_t>(kWalkFrames + kAfterFrames));
  std::ostringstream a, b;
  WriteOctoMapBinaryStream(direct.tree(), a);
  WriteOctoMapBinaryStream(ahead.tree(), b);
  EXPECT_GT(a.str().size(), 1000u);
  EXPECT_EQ(a.str(), b.str());
  // A pose update or removal is not a keyframe to insert, with a cloud or without.
  KeyframeData update;
  update.id = 3;
  update.pose_update_only = true;
  EXPECT_THROW(ahead.Insert(update, StaticCloud{}), InputError);
}

TEST(OctoMapBuilder, BinaryStreamMatchesOctoMapAndPrintsNothing) {
  octomap::OcTree tree(0.05);
  for (int i = 0; i < 2000; ++i)
    tree.updateNode(octomap::point3d(0.013f * i, 0.007f * i, 0.05f * (i % 37)), i % 3 != 0);
  std::ostringstream library;
  ASSERT_TRUE(tree.writeBinaryConst(library));
  std::ostringstream ours;
  ::testing::internal::CaptureStderr();
  WriteOctoMapBinaryStream(tree, ours);
  const std::string printed = ::testing::internal::GetCapturedStderr();
  EXPECT_EQ(printed, "");
  EXPECT_EQ(ours.str(), library.str());
  // An empty tree: header only, as OctoMap writes it.
  octomap::OcTree empty(0.1);
  std::ostringstream empty_library, empty_ours;
  ASSERT_TRUE(empty.writeBinaryConst(empty_library));
  WriteOctoMapBinaryStream(empty, empty_ours);
  EXPECT_EQ(empty_ours.str(), empty_library.str());
}

}  // namespace
}  // namespace dygslam
