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
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

std::string Config() { return std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/bonn.yaml"; }

bool Contains(const std::string& text, const std::string& needle) {
  return text.find(needle) != std::string::npos;
}

class DetectionsCli : public ::testing::Test {
 protected:
  void SetUp() override {
    DYGSLAM_REQUIRE_FILE(testing::DygslamBinary(), "dygslam binary");
    dir_ = testing::MakeTempDir("datasets_detections_cli");
  }
  void TearDown() override { fs::remove_all(dir_); }
  testing::ProcessResult Run(const std::vector<std::string>& args) {
    return testing::RunDygslam(args, dir_);
  }
  static void ExpectError(const testing::ProcessResult& r, int code,
                          const std::vector<std::string>& needles) {
    EXPECT_EQ(r.code, code) << r.err;
    EXPECT_FALSE(Contains(r.err, "internal error")) << r.err;
    for (const std::string& n : needles)
      EXPECT_TRUE(Contains(r.err, n)) << "'" << n << "' not in\n" << r.err.substr(0, 3000);
  }
  // The first `n` frames of bonn_crowd_part (images by absolute path) in dir_/name.
  std::string SmallDataset(const std::string& source, size_t n, const std::string& name) {
    const fs::path dir = fs::path(dir_) / name;
    fs::create_directories(dir);
    const RgbdDataset d = RgbdDataset::Open(source);
    std::ofstream rgb(dir / "rgb.txt"), depth(dir / "depth.txt");
    for (size_t i = 0; i < n; ++i) {
      rgb << d.frame(i).rgb_stamp.ToString() << " " << d.frame(i).rgb_path << "\n";
      depth << d.frame(i).depth_stamp.ToString() << " " << d.frame(i).depth_path << "\n";
    }
    fs::copy_file(d.groundtruth_path(), dir / "groundtruth.txt");
    return dir.string();
  }
  std::string dir_;
};

// Boxes outside the image are said, with their count.
TEST_F(DetectionsCli, DetectionsOutsideTheImageAreWarned) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string ds = SmallDataset(source, 4, "ds");
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
