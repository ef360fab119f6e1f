// Plausibility: inputs that parse but cannot be what they claim give a clear warning or error
// instead of a silently wrong result. Depth that no RGB-D sensor measures on most pixels (every
// pixel at 65535, DepthMapFactor 1 putting the scene thousands of metres away), ground truth with
// coordinates of 1e300 (`run` printed "ATE RMSE inf m"), huge finite errors in `eval` (a line cut
// at a fixed buffer), and `map --trajectory` that gives no frame a pose (an empty map, exit 0).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "core/io/dataset.h"
#include "tests/support/cli_fixture.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;
using testing::Contains;
using testing::ReadAll;

// A dataset of `n` frames whose depth images all hold `raw_depth` (the rgb images of a real one).
std::string ConstantDepthDataset(const std::string& source, const std::string& dir, size_t n,
                                 uint16_t raw_depth) {
  fs::create_directories(fs::path(dir) / "depth");
  const RgbdDataset d = RgbdDataset::Open(source);
  std::ofstream rgb(fs::path(dir) / "rgb.txt"), depth(fs::path(dir) / "depth.txt");
  const cv::Mat image(480, 640, CV_16UC1, cv::Scalar(raw_depth));
  for (size_t i = 0; i < n; ++i) {
    const std::string name = "depth/" + std::to_string(i) + ".png";
    cv::imwrite((fs::path(dir) / name).string(), image);
    rgb << d.frame(i).rgb_stamp.ToString() << " " << d.frame(i).rgb_path << "\n";
    depth << d.frame(i).depth_stamp.ToString() << " " << name << "\n";
  }
  return dir;
}

TEST(DepthPlausibility, MostPixelsOutsideTheSensorRangeAreReported) {
  const std::string source = testing::DatasetDir("bonn_crowd_part");
  if (source.empty()) {
    if (testing::RequireData()) FAIL() << "bonn_crowd_part missing";
    GTEST_SKIP() << "bonn_crowd_part missing";
  }
  const RgbdDataset real = RgbdDataset::Open(source);
  // The real sequence at its factor: plausible. Its median depth is a few metres.
  const DepthRangeSample ok = SampleDepthRange(real, 0, real.num_rgb_entries(), 5000, 640, 480);
  EXPECT_EQ(ok.images, 5u);
  EXPECT_GT(ok.median_m, 0.5);
  EXPECT_LT(ok.median_m, 6.0);
  EXPECT_EQ(ImplausibleDepth(ok, 5000), "");
  // DepthMapFactor 1: every metre becomes 5000 m.
  const std::string far =
      ImplausibleDepth(SampleDepthRange(real, 0, real.num_rgb_entries(), 1, 640, 480), 1);
  EXPECT_TRUE(Contains(far, "lie beyond 12 m")) << far;
  EXPECT_TRUE(Contains(far, "DepthMapFactor 1)")) << far;
  // DepthMapFactor 1e6: every pixel a few millimetres away.
  const std::string near =
      ImplausibleDepth(SampleDepthRange(real, 0, real.num_rgb_entries(), 1e6, 640, 480), 1e6);
  EXPECT_TRUE(Contains(near, "closer than 0.05 m")) << near;
  // DepthMapFactor 1e5 (20 times the sequence's): most pixels still beyond 5 cm, but the median
  // scene within arm's reach.
  const std::string close =
      ImplausibleDepth(SampleDepthRange(real, 0, real.num_rgb_entries(), 1e5, 640, 480), 1e5);
  EXPECT_TRUE(Contains(close, "the median depth of 5 sampled depth images")) << close;
  EXPECT_TRUE(Contains(close, "DepthMapFactor 100000: closer than 0.5 m")) << close;
  // 10 times the sequence's: the median a few decimetres away.
  const std::string tenfold =
      ImplausibleDepth(SampleDepthRange(real, 0, real.num_rgb_entries(), 5e4, 640, 480), 5e4);
  EXPECT_TRUE(Contains(tenfold, "DepthMapFactor 50000: closer than 0.5 m")) << tenfold;
  // Saturated images: every pixel 65535 (13.1 m at 5000).
  const std::string dir = testing::MakeTempDir("plausible_depth");
  const RgbdDataset saturated =
      RgbdDataset::Open(ConstantDepthDataset(source, dir + "/saturated", 6, 65535));
  const DepthRangeSample s = SampleDepthRange(saturated, 0, 6, 5000, 640, 480);
  EXPECT_EQ(s.beyond, s.valid);
  EXPECT_TRUE(Contains(ImplausibleDepth(s, 5000), "100 % of the depth pixels"))
      << ImplausibleDepth(s, 5000);
  EXPECT_TRUE(Contains(ImplausibleDepth(s, 5000), "saturated")) << ImplausibleDepth(s, 5000);
}

class PlausibilityCli : public testing::CliFixture {
 protected:
  PlausibilityCli() : CliFixture("plausibility_cli") {}
};

TEST_F(PlausibilityCli, RunWarnsAboutDepthNoSensorMeasures) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string data = ConstantDepthDataset(source, dir_ + "/saturated", 12, 65535);
  const auto r = Run({"run", data, "--config", Config(), "--direct", "--filter", "none", "--quiet",
                      "--no-map", "--out", dir_ + "/out"});
  EXPECT_TRUE(Contains(r.err, "dygslam run: warning: implausible depth: 100 % of the depth pixels"))
      << r.err;
  // The settings' DepthMapFactor 1 on the real images.
  std::ofstream(dir_ + "/factor1.yaml") << std::regex_replace(
      ReadAll(Config()), std::regex("DepthMapFactor: *[0-9.]+"), "DepthMapFactor: 1.0");
  const std::string real = SmallDataset(source, 12, "real");
  const auto f = Run({"run", real, "--config", dir_ + "/factor1.yaml", "--direct", "--filter",
                      "none", "--quiet", "--no-map", "--out", dir_ + "/out1"});
  EXPECT_TRUE(Contains(f.err, "implausible depth:")) << f.err;
  EXPECT_TRUE(Contains(f.err, "with DepthMapFactor 1)")) << f.err;
  // The right factor: no warning.
  const auto good = Run({"run", real, "--config", Config(), "--direct", "--filter", "none",
                         "--quiet", "--no-map", "--out", dir_ + "/out2"});
  EXPECT_EQ(good.code, 0) << good.err;
  EXPECT_FALSE(Contains(good.err, "implausible")) << good.err;
}

TEST_F(PlausibilityCli, RunRefusesGroundTruthNoCameraReaches) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string data = SmallDataset(source, 30, "data", /*with_groundtruth=*/true);
  // One coordinate of 1e300 in the ground truth (the x of its first pose).
  std::istringstream lines(ReadAll(data + "/groundtruth.txt"));
  std::string gt, line;
  bool replaced = false;
  while (std::getline(lines, line)) {
    if (!replaced && !line.empty() && line[0] != '#') {
      std::istringstream fields(line);
      std::string stamp, x, rest;
      fields >> stamp >> x;
      std::getline(fields, rest);
      line = stamp + " 1e300" + rest;
      replaced = true;
    }
    gt += line + "\n";
  }
  ASSERT_TRUE(replaced);
  std::ofstream(data + "/groundtruth.txt") << gt;
  const auto r = Run({"run", data, "--config", Config(), "--direct", "--filter", "none", "--quiet",
                      "--no-map", "--out", dir_ + "/out"});
  EXPECT_TRUE(Contains(r.err, "coordinate 1e+300 m is beyond 1e+07 m (not a camera trajectory)"))
      << r.err;
  EXPECT_FALSE(Contains(r.out, "ATE RMSE")) << r.out;
  EXPECT_FALSE(Contains(r.out, "inf")) << r.out;
  EXPECT_TRUE(Contains(r.out, "ATE: not evaluated")) << r.out;
}

// Coordinates no camera reaches (1e30, 1e150 m) are refused by every command that reads a
// trajectory, naming the file and line: before, `eval` printed a line cut short, and `map
// --trajectory` and `bench` accepted them.
TEST_F(PlausibilityCli, TrajectoriesWithCoordinatesNoCameraReachesAreRefused) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string data = SmallDataset(source, 10, "data", /*with_groundtruth=*/true);
  const std::string gt = dir_ + "/gt.txt", est = dir_ + "/est.txt";
  for (const double far : {1e30, 1e150}) {
    {
      std::ofstream g(gt), e(est);
      for (int i = 0; i < 40; ++i) {
        g << 100 + 0.1 * i << " " << 0.01 * i << " 0 0 0 0 0 1\n";
        e << 100 + 0.1 * i << " " << (i == 3 ? far : 0.0) << " 0 0 0 0 0 1\n";
      }
    }
    ExpectError(Run({"eval", gt, est}), 1, {est + ":4", "is beyond 1e+07 m"});
  }
  // map --trajectory: the poses of the dataset's frames, one of them far away.
  std::istringstream lines(ReadAll(data + "/groundtruth.txt"));
  std::string far_gt, line;
  int data_lines = 0;
  while (std::getline(lines, line)) {
    if (!line.empty() && line[0] != '#' && ++data_lines == 2) {
      std::istringstream fields(line);
      std::string stamp, x, rest;
      fields >> stamp >> x;
      std::getline(fields, rest);
      line = stamp + " 1e30" + rest;
    }
    far_gt += line + "\n";
  }
  std::ofstream(dir_ + "/far.txt") << far_gt;
  ExpectError(Run({"map", data, "--config", Config(), "--trajectory", dir_ + "/far.txt", "--out",
                   dir_ + "/out", "--quiet"}),
              1, {dir_ + "/far.txt", "is beyond 1e+07 m"});
  EXPECT_FALSE(fs::exists(dir_ + "/out/map.bt"));
}

TEST_F(PlausibilityCli, MapFromATrajectoryThatMatchesNoFrameIsAnError) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string data = SmallDataset(source, 10, "data");
  const std::string trajectory = dir_ + "/other_sequence.txt";
  {
    std::ofstream f(trajectory);
    for (int i = 0; i < 20; ++i) f << 1000 + 0.1 * i << " 0 0 0 0 0 0 1\n";
  }
  const auto r = Run({"map", data, "--config", Config(), "--trajectory", trajectory, "--out",
                      dir_ + "/out", "--quiet"});
  ExpectError(r, 1,
              {trajectory, "--trajectory gives none of the range's frames a pose",
               "poses from 1000", "the range has 10 frames"});
  EXPECT_FALSE(fs::exists(dir_ + "/out/map.bt"));
}

}  // namespace
}  // namespace dygslam
