// `dygslam run --direct` on a dataset whose image does not decode mid-run: exit 1 after writing
// the outputs of the frames before it; the message says how many frames they hold.
#include <gtest/gtest.h>
#include <octomap/OcTree.h>
#include <sys/stat.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "core/io/dataset.h"
#include "core/io/trajectory_io.h"
#include "mapping/octomap_builder.h"
#include "tests/support/cli_fixture.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

using testing::Contains;
using testing::ReadAll;

class UndecodableImageRun : public testing::CliFixture {
 protected:
  UndecodableImageRun() : CliFixture("images_undecodable_run") {}
};

// A direct run that failed mid-way (an image that does not decode) wrote nothing. The frames
// before the error are written (atomically) and the run says so, exit 1.
TEST_F(UndecodableImageRun, DirectRunThatFailsLateWritesWhatWasComputed) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string dataset = SmallDataset(source, 30, "late");
  // Entry 20's colour image: a truncated copy.
  const RgbdDataset d = RgbdDataset::Open(dataset);
  const std::string bytes = ReadAll(d.frame(20).rgb_path);
  const std::string broken = dataset + "/broken.png";
  std::ofstream(broken, std::ios::binary) << bytes.substr(0, bytes.size() / 3);
  std::string rgb = ReadAll(dataset + "/rgb.txt");
  const std::string old_path = d.frame(20).rgb_path;
  rgb.replace(rgb.find(old_path), old_path.size(), "broken.png");
  std::ofstream(dataset + "/rgb.txt") << rgb;
  const std::string out = dir_ + "/late_out";
  const auto r = Run({"run", dataset, "--config", Config(), "--out", out, "--filter", "none",
                      "--direct", "--quiet"});
  ExpectError(r, 1,
              {"broken.png", "rgb.txt:21", "stopped by an error after 20 frames",
               "outputs of those frames are written"});
  const auto trajectory = ReadTumTrajectory(out + "/trajectory.txt");
  EXPECT_GE(trajectory.size(), 18u);
  EXPECT_LE(trajectory.size(), 20u);
  const std::string csv = ReadAll(out + "/frames.csv");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 21);  // header + the 20 frames
  EXPECT_TRUE(fs::exists(out + "/map.bt"));
  for (const auto& e : fs::directory_iterator(out))
    EXPECT_FALSE(Contains(e.path().filename().string(), ".tmp.")) << e.path();
}

}  // namespace
}  // namespace dygslam
