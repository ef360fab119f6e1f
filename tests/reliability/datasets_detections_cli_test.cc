// A --detections file whose boxes lie outside the image: the run warns how many (they mask
// nothing) and goes on.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/types.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "core/io/dataset.h"
#include "tests/support/cli_fixture.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

using testing::Contains;

class DetectionsCli : public testing::CliFixture {
 protected:
  DetectionsCli() : CliFixture("datasets_detections_cli") {}
  void TearDown() override { fs::remove_all(dir_); }
};

// Boxes outside the image are said, with their count.
TEST_F(DetectionsCli, DetectionsOutsideTheImageAreWarned) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string ds = SmallDataset(source, 4, "ds", /*with_groundtruth=*/true);
  const RgbdDataset d = RgbdDataset::Open(ds);
  std::ofstream det(dir_ + "/det.txt");
  for (size_t i = 0; i < d.size(); ++i) {
    const std::string stamp = d.frame(i).rgb_stamp.ToString();
    det << stamp << " 100 100 50 80 0 0.9\n";      // inside
    det << stamp << " 1e6 1e6 50 80 0 0.9\n";      // far outside
    det << stamp << " -200 -300 100 100 0 0.9\n";  // outside, above the top-left corner
  }
  det.close();
  const auto r = Run({"run", ds, "--config", Config(), "--out", dir_ + "/o", "--direct", "--filter",
                      "boxes", "--detections", dir_ + "/det.txt", "--quiet"});
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(Contains(r.err, "8 of its 12 boxes lie outside the 640x480 image")) << r.err;
}

}  // namespace
}  // namespace dygslam
