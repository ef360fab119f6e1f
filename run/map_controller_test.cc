// The map controller on the first frames of bonn_crowd_part: from the ground truth's poses and
// from the SLAM (filter none: no detector), and its checks.
#include "run/map_controller.h"

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <filesystem>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/io/trajectory_io.h"
#include "mapping/octomap_builder.h"
#include "run/run_settings.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

MapControllerOptions Options(const std::string& dataset, const std::string& out, size_t last) {
  RunSettingsRequest request;
  request.settings_path = std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/bonn.yaml";
  request.read.print_warnings = false;
  request.filter = "none";
  request.deterministic = true;
  const RunConfiguration c = LoadRunConfiguration(request);
  MapControllerOptions o;
  o.dataset_dir = dataset;
  o.system = c.system;
  o.octomap = c.octomap;
  o.octomap.use_dynamic_mask = false;
  o.first = 0;
  o.last = last;
  o.out = out;
  o.progress = false;
  return o;
}

size_t OccupiedLeaves(const std::string& path) {
  const auto tree = ReadOctoMap(path);
  size_t n = 0;
  for (auto it = tree->begin_leafs(), end = tree->end_leafs(); it != end; ++it)
    n += tree->isNodeOccupied(*it) ? 1 : 0;
  return n;
}

TEST(MapController, BuildsTheMapFromGivenPoses) {
  DYGSLAM_REQUIRE_DATASET(dir, "bonn_crowd_part");
  const std::string out = testing::MakeTempDir("map_controller_poses");
  const RgbdDataset dataset = RgbdDataset::Open(dir);
  MapControllerOptions o = Options(dir, out, 30);
  o.given_poses = ReadTumTrajectory(dataset.groundtruth_path());
  o.trajectory_path = dataset.groundtruth_path();
  o.every = 10;
  o.bonn_marker = true;
  MapController controller(o, dataset);
  EXPECT_EQ(controller.Run(), 0);
  for (const char* name : {"map.bt", "map.ot", "map_top.png", "map_slice.png"})
    EXPECT_TRUE(fs::exists(out + "/" + name)) << name;
  EXPECT_FALSE(fs::exists(out + "/trajectory.txt")) << "no SLAM, no trajectory";
  EXPECT_GT(OccupiedLeaves(out + "/map.bt"), 1000u);
}

TEST(MapController, BuildsTheMapFromTheSlamKeyframes) {
  DYGSLAM_REQUIRE_DATASET(dir, "bonn_crowd_part");
  const std::string out = testing::MakeTempDir("map_controller_slam");
  const RgbdDataset dataset = RgbdDataset::Open(dir);
  MapController controller(Options(dir, out, 20), dataset);
  EXPECT_EQ(controller.Run(), 0);
  EXPECT_EQ(ReadTumTrajectory(out + "/trajectory.txt").size(), 20u);
  EXPECT_GE(ReadTumTrajectory(out + "/keyframes.txt").size(), 1u);
  EXPECT_GT(OccupiedLeaves(out + "/map.bt"), 1000u);
}

TEST(MapController, PosesOfAnotherSequenceAreAnErrorNamingTheFile) {
  DYGSLAM_REQUIRE_DATASET(dir, "bonn_crowd_part");
  const std::string out = testing::MakeTempDir("map_controller_other");
  const RgbdDataset dataset = RgbdDataset::Open(dir);
  MapControllerOptions o = Options(dir, out, 30);
  std::vector<StampedPose> other;
  for (int i = 0; i < 10; ++i) other.push_back({Timestamp::FromSeconds(10.0 + i), Rigid3d()});
  o.given_poses = other;
  o.trajectory_path = "other_sequence.txt";
  try {
    MapController controller(o, dataset);
    ADD_FAILURE() << "accepted poses that match no frame";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("other_sequence.txt"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("another sequence"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(out + "/map.bt"));
}

TEST(MapControllerOptions, CheckNamesTheField) {
  MapControllerOptions o;
  o.dataset_dir = "data";
  o.out = "out";
  EXPECT_NO_THROW(o.Check());
  MapControllerOptions bad = o;
  bad.every = 5;  // without given poses
  EXPECT_THROW(bad.Check(), InvalidOptions);
  bad = o;
  bad.save_every_s = 0.0;
  try {
    bad.Check();
    ADD_FAILURE() << "accepted save_every_s 0";
  } catch (const InvalidOptions& e) {
    EXPECT_NE(std::string(e.what()).find("save_every_s"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace dygslam
