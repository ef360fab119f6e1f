// A DDS run (default mode, domain 200 inside the netns emulator) applies Detector.every_n_frames
// and leaves a groundtruth.txt of the user's in --out as it was.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "core/base/stop_signal.h"
#include "core/io/dataset.h"
#include "core/io/trajectory_io.h"
#include "tests/support/cli_fixture.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

using testing::Contains;

class DdsRunCadence : public testing::CliFixture {
 protected:
  DdsRunCadence() : CliFixture("dds_peers_cadence") {}

  // Replaces rgb.txt entry `entry`'s image by a truncated copy named broken.png.
  void BreakImage(const std::string& dataset, size_t entry) {
    const RgbdDataset d = RgbdDataset::Open(dataset);
    const std::string bytes = testing::ReadAll(d.frame(entry).rgb_path);
    std::ofstream(dataset + "/broken.png", std::ios::binary) << bytes.substr(0, bytes.size() / 3);
    std::string rgb = testing::ReadAll(dataset + "/rgb.txt");
    const std::string old_path = d.frame(entry).rgb_path;
    rgb.replace(rgb.find(old_path), old_path.size(), "broken.png");
    std::ofstream(dataset + "/rgb.txt") << rgb;
  }
};

// Items 3, 14 and 7 in the DDS mode (domain 200): the cadence is applied in the DDS modes (no
// "not applied" warning any more; dds/Cadence checks the trajectories), a user's groundtruth.txt
// in --out kept, a long --partition echoed bounded in the banner.
TEST_F(DdsRunCadence, DdsRunAppliesTheCadenceAndKeepsTheUsersGroundTruth) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  DYGSLAM_REQUIRE_MODELS(models);
  const std::string dataset = SmallDataset(source, 10, "dds", /*with_groundtruth=*/true);
  const std::string settings = dir_ + "/every3.yaml";
  {
    // The preset's own Detector.every_n_frames line is replaced (a key given twice is an error).
    std::istringstream preset(testing::ReadAll(Config()));
    std::ofstream out(settings);
    for (std::string line; std::getline(preset, line);)
      if (line.rfind("Detector.every_n_frames", 0) != 0) out << line << "\n";
    out << "Detector:\n  every_n_frames: 3\n";
  }
  const std::string out = dir_ + "/o_dds";
  fs::create_directories(out);
  const std::string mine = "# my own ground truth, not the dataset's\n1 0 0 0 0 0 0 1\n";
  std::ofstream(out + "/groundtruth.txt") << mine;
  const std::string partition(1000, 'p');
  const auto r = Run({"run", dataset, "--config", settings, "--out", out, "--quiet", "--domain",
                      "200", "--partition", partition});
  EXPECT_EQ(r.code, 0) << r.err.substr(0, 4000);
  EXPECT_FALSE(Contains(r.err, "every_n_frames")) << r.err.substr(0, 4000);
  EXPECT_EQ(testing::ReadAll(out + "/groundtruth.txt"), mine);
  EXPECT_TRUE(Contains(r.err, "was there before this run")) << r.err.substr(0, 4000);
  EXPECT_GE(ReadTumTrajectory(out + "/trajectory.txt").size(), 8u);
  const size_t banner = r.err.find("[run] DDS partition");
  ASSERT_NE(banner, std::string::npos) << r.err.substr(0, 2000);
  EXPECT_LT(r.err.find('\n', banner) - banner, 600u);
  EXPECT_TRUE(Contains(r.err, "(1000 bytes)")) << r.err.substr(0, 1000);
}

}  // namespace
}  // namespace dygslam
