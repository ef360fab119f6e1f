// Detector cadence through DDS: with `Detector.every_n_frames: 3` the detector
// component detects every 3rd frame only and slam carries the boxes to the frames in between (the
// System's box propagation, as in the direct loop); slam does not wait for the skipped frames, so
// --deterministic stays deterministic: the direct loop, the pipeline on threads of one process and
// one process per component write the same trajectory, byte for byte. 60 frames with people in
// view (rgb.txt entries 100-160 of bonn_crowd_part). Keyframes made on skipped frames get their
// map mask from slam's own detector, as in the direct loop: the same map.bt in all modes. Runs
// the dygslam binary inside the test's network namespace; DDS domains 225-226 and 185-186.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "core/io/trajectory_io.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {

using testing::ReadAll;

std::string Binary() {
  if (const char* dir = std::getenv("DYGSLAM_BINARY_DIR"))
    return std::string(dir) + "/apps/dygslam";
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe");
  return (self.parent_path().parent_path() / "apps" / "dygslam").string();
}

// config/bonn.yaml with Detector.every_n_frames set to `every_n` (a line setting it in the file,
// ORB-SLAM2's dotted form, is dropped; the key is appended in a Detector section).
std::string ConfigWithCadence(const std::string& dir, int every_n) {
  std::ifstream in(std::string(std::getenv("DYGSLAM_SOURCE_DIR")) + "/config/bonn.yaml");
  std::string text, line;
  while (std::getline(in, line)) {
    if (line.rfind("Detector.every_n_frames:", 0) != 0) text += line + "\n";
  }
  const std::string path = dir + "/cadence.yaml";
  std::ofstream(path) << text << "\nDetector:\n  every_n_frames: " << every_n << "\n";
  return path;
}

// `dygslam run` on rgb.txt entries `frames`, --deterministic, full filter, --no-map unless `map`,
// output and log in dir/name.
int RunMode(const std::string& dataset, const std::string& config, const std::string& dir,
            const std::string& name, const std::string& extra,
            const std::string& frames = "100:160", bool map = false) {
  std::ostringstream command;
  command << Binary() << " run " << dataset << " --config " << config << " --frames " << frames
          << (map ? "" : " --no-map") << " --deterministic --filter full --out " << dir << "/"
          << name << " " << extra << " > " << dir << "/" << name << ".log 2>&1";
  const int status = std::system(command.str().c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

TEST(Cadence, DeterministicTrajectoryIdenticalInAllModes) {
  DYGSLAM_REQUIRE_DATASET(dataset, "bonn_crowd_part");
  const std::string tmp = testing::MakeTempDir("dds_cadence");
  const std::string config = ConfigWithCadence(tmp, 3);
  ASSERT_EQ(RunMode(dataset, config, tmp, "direct", "--direct"), 0) << ReadAll(tmp + "/direct.log");
  ASSERT_EQ(RunMode(dataset, config, tmp, "single", "--domain 225"), 0)
      << ReadAll(tmp + "/single.log");
  ASSERT_EQ(RunMode(dataset, config, tmp, "multi", "--domain 226 --processes"), 0)
      << ReadAll(tmp + "/multi.log");
  const std::string direct = ReadAll(tmp + "/direct/trajectory.txt");
  EXPECT_GT(ReadTumTrajectory(tmp + "/direct/trajectory.txt").size(), 55u);
  EXPECT_EQ(ReadAll(tmp + "/single/trajectory.txt"), direct) << ReadAll(tmp + "/single.log");
  EXPECT_EQ(ReadAll(tmp + "/multi/trajectory.txt"), direct) << ReadAll(tmp + "/multi.log");
  for (const std::string mode : {"single", "multi"}) {
    const std::string log = ReadAll(tmp + "/" + mode + ".log");
    // Frames 0, 3, ..., 57 detected (20), the other 40 carried: the detector component skipped
    // them and slam fed them with the System's carried boxes without waiting.
    EXPECT_NE(log.find("detector: 20 frames"), std::string::npos) << mode << "\n" << log;
    EXPECT_NE(log.find("40 frames skipped"), std::string::npos) << mode << "\n" << log;
    EXPECT_NE(log.find("40 skipped by the detector cadence"), std::string::npos) << mode << "\n"
                                                                                 << log;
    EXPECT_NE(log.find("frames: 60 processed"), std::string::npos) << mode << "\n" << log;
  }
}

// The detector component skips 2 frames of 3; a keyframe made on a skipped
// frame gets its map mask from slam's own detector (created on first use, the detector
// component's model and thread count), as `--direct` does with its own detector: the OctoMap of
// entries 100-145 (8 keyframes, 6 on skipped frames) is the same, byte for byte, in the direct
// loop, on threads of one process and with one process per component. With the carried boxes
// for those masks (before) the DDS maps differed from the direct one.
TEST(Cadence, KeyframesOfSkippedFramesGetTheSameMapMaskAsDirect) {
  DYGSLAM_REQUIRE_DATASET(dataset, "bonn_crowd_part");
  const std::string tmp = testing::MakeTempDir("dds_cadence_map");
  const std::string config = ConfigWithCadence(tmp, 3);
  const std::string frames = "100:145";
  ASSERT_EQ(RunMode(dataset, config, tmp, "direct", "--direct", frames, true), 0)
      << ReadAll(tmp + "/direct.log");
  ASSERT_EQ(RunMode(dataset, config, tmp, "single", "--domain 185", frames, true), 0)
      << ReadAll(tmp + "/single.log");
  ASSERT_EQ(RunMode(dataset, config, tmp, "multi", "--domain 186 --processes", frames, true), 0)
      << ReadAll(tmp + "/multi.log");
  const std::string direct_map = ReadAll(tmp + "/direct/map.bt");
  ASSERT_GT(direct_map.size(), 1000u) << ReadAll(tmp + "/direct.log");
  const std::string direct = ReadAll(tmp + "/direct/trajectory.txt");
  for (const std::string mode : {"single", "multi"}) {
    const std::string log = ReadAll(tmp + "/" + mode + ".log");
    EXPECT_EQ(ReadAll(tmp + "/" + mode + "/trajectory.txt"), direct) << mode << "\n" << log;
    EXPECT_NE(log.find("30 frames skipped"), std::string::npos) << mode << "\n" << log;
    EXPECT_TRUE(ReadAll(tmp + "/" + mode + "/map.bt") == direct_map)
        << mode << ": map.bt differs from the direct loop's\n"
        << log;
  }
}

}  // namespace
}  // namespace dygslam
