// `dygslam map` on a dataset whose image does not decode mid-run: every output of the frames
// before it is written atomically, and the command exits 1.
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

class UndecodableImageMap : public testing::CliFixture {
 protected:
  UndecodableImageMap() : CliFixture("images_undecodable_map") {}

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

// Every output of `map` from the frames before the error, atomically; exit 1.
TEST_F(UndecodableImageMap, MapThatFailsLateWritesEveryOutput) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string dataset = SmallDataset(source, 30, "late");
  BreakImage(dataset, 20);
  const std::string out = dir_ + "/late_map";
  const auto r = Run({"map", dataset, "--config", Config(), "--out", out, "--filter", "none",
                      "--deterministic", "--quiet"});
  ExpectError(r, 1, {"broken.png", "rgb.txt:21", "[map] stopped by an error after 20 frames"});
  for (const char* name :
       {"map.bt", "map.ot", "map_top.png", "map_slice.png", "trajectory.txt", "keyframes.txt"})
    EXPECT_TRUE(fs::is_regular_file(fs::path(out) / name)) << name << "\n" << r.err;
  const auto trajectory = ReadTumTrajectory(out + "/trajectory.txt");
  EXPECT_GE(trajectory.size(), 18u);
  EXPECT_LE(trajectory.size(), 20u);
  for (const auto& e : fs::directory_iterator(out))
    EXPECT_FALSE(Contains(e.path().filename().string(), ".tmp.")) << e.path();
}

}  // namespace
}  // namespace dygslam
