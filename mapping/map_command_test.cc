// `dygslam map` end to end (runs the binary): outputs exist and open, errors name what is wrong.
#include <gtest/gtest.h>
#include <octomap/OcTree.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "mapping/octomap_builder.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

struct Result {
  int exit_code = -1;
  std::string output;  // stdout + stderr
};

std::string Binary() {
  if (const char* dir = std::getenv("DYGSLAM_BINARY_DIR"))
    return std::string(dir) + "/apps/dygslam";
  // <build>/mapping/mapping_map_command_test -> <build>/apps/dygslam
  const fs::path self = fs::read_symlink("/proc/self/exe");
  return (self.parent_path().parent_path() / "apps" / "dygslam").string();
}

Result RunDygslam(const std::string& args) {
  Result r;
  const std::string command = Binary() + " " + args + " 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return r;
  std::array<char, 4096> buffer;
  size_t n;
  while ((n = fread(buffer.data(), 1, buffer.size(), pipe)) > 0) r.output.append(buffer.data(), n);
  const int status = pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

size_t OccupiedLeaves(const octomap::OcTree& tree) {
  size_t n = 0;
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it)
    n += tree.isNodeOccupied(*it);
  return n;
}

TEST(MapCommand, GroundTruthMapWithReferenceWritesEverything) {
  DYGSLAM_REQUIRE_DATASET(dir, "bonn_crowd_part");
  DYGSLAM_REQUIRE_FILE(Binary(), "dygslam binary");
  const std::string out = testing::MakeTempDir("map_command");
  const Result r = RunDygslam("map " + dir + " --trajectory " + dir +
                              "/groundtruth.txt --bonn-marker --every 20 --quiet" +
                              " --reference-until 100 --resolution 0.1 --out " + out);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("ghost voxels:"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("insertion per keyframe"), std::string::npos) << r.output;
  for (const char* name : {"map.bt", "map.ot", "reference.bt"}) {
    const auto tree = ReadOctoMap(out + "/" + name);
    EXPECT_DOUBLE_EQ(tree->getResolution(), 0.1) << name;
    EXPECT_GT(OccupiedLeaves(*tree), 500u) << name;
  }
  for (const char* name : {"map_top.png", "map_slice.png", "ghosts_top.png"}) {
    const cv::Mat image = cv::imread(out + "/" + name);
    EXPECT_GT(image.cols, 20) << name;
  }
  EXPECT_TRUE(fs::exists(out + "/ghost_cells.txt"));
  // No temporary files left behind.
  for (const auto& entry : fs::directory_iterator(out)) {
    EXPECT_EQ(entry.path().string().find(".tmp"), std::string::npos) << entry.path();
  }
}

TEST(MapCommand, SlamRunWritesLevelledMapAndTrajectory) {
  DYGSLAM_REQUIRE_DATASET(dir, "bonn_crowd_part");
  DYGSLAM_REQUIRE_FILE(Binary(), "dygslam binary");
  const std::string out = testing::MakeTempDir("map_command_slam");
  const Result r = RunDygslam(
      "map " + dir +
      " --frames 0:40 --filter none --deterministic --quiet --resolution 0.1 --out " + out);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("map frame: levelled on the floor"), std::string::npos) << r.output;
  EXPECT_TRUE(fs::exists(out + "/trajectory.txt"));
  EXPECT_TRUE(fs::exists(out + "/keyframes.txt"));
  const auto tree = ReadOctoMap(out + "/map.bt");
  EXPECT_GT(OccupiedLeaves(*tree), 300u);
  // Levelled: the floor is at z = 0, so most occupied cells are above -0.2 m.
  size_t below = 0, total = 0;
  for (auto it = tree->begin_leafs(), end = tree->end_leafs(); it != end; ++it) {
    if (!tree->isNodeOccupied(*it)) continue;
    ++total;
    below += it.getZ() < -0.2;
  }
  EXPECT_LT(below, total / 20) << below << " of " << total;
}

TEST(MapCommand, BadInputIsNamed) {
  DYGSLAM_REQUIRE_FILE(Binary(), "dygslam binary");
  const std::string tmp = testing::MakeTempDir("map_command_bad");
  // Usage errors: exit 2.
  Result r = RunDygslam("map " + tmp + " --resolution -1");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--resolution"), std::string::npos) << r.output;
  r = RunDygslam("map " + tmp + " --every 3");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--trajectory"), std::string::npos) << r.output;
  // A settings file with a bad OctoMap value: exit 1 naming file, line and key.
  const std::string yaml = tmp + "/bad.yaml";
  std::ofstream(yaml) << "Camera.fx: 500\nCamera.fy: 500\nCamera.cx: 320\nCamera.cy: 240\n"
                         "Camera.k1: 0\nCamera.k2: 0\nCamera.p1: 0\nCamera.p2: 0\n"
                         "OctoMap:\n  resolution: 0.05\n  prob_miss: 0.7\n";
  r = RunDygslam("map " + tmp + " --config " + yaml);
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find(yaml + ":11"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("OctoMap.prob_miss"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace dygslam
