#include "core/io/dataset.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <set>

#include "core/base/error.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

void WriteText(const fs::path& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
}

// A small TUM-layout folder with `n` frames (rgb at 30 Hz, depth 5 ms later).
class SmallDataset : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::MakeTempDir("io_dataset");
    fs::create_directories(dir_ / "rgb");
    fs::create_directories(dir_ / "depth");
    std::string rgb_list = "# color images\n# timestamp filename\n";
    std::string depth_list = "# depth maps\n";
    for (int i = 0; i < 4; ++i) {
      const std::string rt = "100." + std::to_string(100 + 33 * i) + "000";
      const std::string dt = "100." + std::to_string(105 + 33 * i) + "000";
      cv::imwrite((dir_ / "rgb" / (rt + ".png")).string(),
                  cv::Mat(24, 32, CV_8UC3, cv::Scalar(10 * i, 20, 30)));
      cv::imwrite((dir_ / "depth" / (dt + ".png")).string(),
                  cv::Mat(24, 32, CV_16UC1, cv::Scalar(5000 + i)));
      rgb_list += rt + " rgb/" + rt + ".png\n";
      depth_list += dt + " depth/" + dt + ".png\n";
    }
    WriteText(dir_ / "rgb.txt", rgb_list);
    WriteText(dir_ / "depth.txt", depth_list);
  }
  // Replaces line `line` (1-based) of `file`.
  void ReplaceLine(const std::string& file, int line, const std::string& text) {
    std::ifstream in(dir_ / file);
    std::string all, l;
    for (int n = 1; std::getline(in, l); ++n) all += (n == line ? text : l) + "\n";
    in.close();
    WriteText(dir_ / file, all);
  }
  void ExpectError(const std::string& needle1, const std::string& needle2) {
    try {
      RgbdDataset::Open(dir_.string());
      ADD_FAILURE() << "expected InputError containing " << needle1;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(needle1), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(needle2), std::string::npos) << e.what();
    }
  }
  fs::path dir_;
};

TEST_F(SmallDataset, OpensAndAssociates) {
  const RgbdDataset d = RgbdDataset::Open(dir_.string());
  ASSERT_EQ(d.size(), 4u);
  EXPECT_EQ(d.num_rgb_entries(), 4u);
  EXPECT_FALSE(d.has_groundtruth());
  for (size_t i = 0; i < d.size(); ++i) {
    EXPECT_NEAR(SecondsBetween(d.frame(i).rgb_stamp, d.frame(i).depth_stamp), 0.005, 1e-12);
    EXPECT_TRUE(fs::path(d.frame(i).rgb_path).is_absolute());
    EXPECT_EQ(d.FrameForRgbEntry(i), i);
  }
  const cv::Mat rgb = d.LoadRgb(2, 32, 24);
  EXPECT_EQ(rgb.type(), CV_8UC3);
  EXPECT_EQ(rgb.at<cv::Vec3b>(0, 0)[0], 20);
  const cv::Mat depth = d.LoadDepth(3, 32, 24);
  EXPECT_EQ(depth.type(), CV_16UC1);
  EXPECT_EQ(depth.at<uint16_t>(5, 5), 5003);
}

TEST_F(SmallDataset, DepthWithoutPartnerLeavesRgbUnmatched) {
  // Move depth of frame 1 out of range: rgb entry 1 has no partner.
  ReplaceLine("depth.txt", 3, "100.160000 depth/100.138000.png");
  const RgbdDataset d = RgbdDataset::Open(dir_.string());
  EXPECT_EQ(d.num_rgb_entries(), 4u);
  // 100.160 is 0.027 from rgb 100.133 (beyond 0.02) and 0.006 from rgb 100.166, whose own depth
  // 100.171 is closer (0.005) and wins; so rgb entry 1 (100.133) has no partner.
  EXPECT_EQ(d.size(), 3u);
  EXPECT_FALSE(d.FrameForRgbEntry(1).has_value());
  EXPECT_EQ(d.FrameForRgbEntry(2), 1u);
}

TEST_F(SmallDataset, MissingDirectory) {
  EXPECT_THROW(RgbdDataset::Open((dir_ / "nope").string()), InputError);
  try {
    RgbdDataset::Open((dir_ / "rgb.txt").string());
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("not a directory"), std::string::npos);
  }
}

TEST_F(SmallDataset, MissingListFiles) {
  fs::remove(dir_ / "depth.txt");
  ExpectError("depth.txt", "not found");
  fs::remove(dir_ / "rgb.txt");
  ExpectError("rgb.txt", "not found");
}

TEST_F(SmallDataset, MalformedLines) {
  ReplaceLine("rgb.txt", 4, "100.166000");
  ExpectError("rgb.txt:4", "expected 2 columns");
  SetUp();
  ReplaceLine("depth.txt", 2, "100.105000 depth/100.105000.png extra");
  ExpectError("depth.txt:2", "expected 2 columns");
  SetUp();
  ReplaceLine("rgb.txt", 3, "1e2 rgb/100.100000.png");
  ExpectError("rgb.txt:3", "malformed timestamp");
}

TEST_F(SmallDataset, UnsortedAndDuplicateTimestamps) {
  ReplaceLine("rgb.txt", 4, "100.050000 rgb/100.133000.png");
  ExpectError("rgb.txt:4", "not sorted");
  SetUp();
  ReplaceLine("depth.txt", 3, "100.105000 depth/100.138000.png");
  ExpectError("depth.txt:3", "duplicate timestamp");
}

TEST_F(SmallDataset, MissingImageFile) {
  fs::remove(dir_ / "rgb" / "100.166000.png");
  ExpectError("rgb.txt:5", "100.166000.png");
}

TEST_F(SmallDataset, NoOverlap) {
  WriteText(dir_ / "depth.txt", "200.000000 depth/100.105000.png\n");
  ExpectError(dir_.string(), "no rgb/depth pairs");
}

TEST_F(SmallDataset, WrongImageSizeOrType) {
  const RgbdDataset d = RgbdDataset::Open(dir_.string());
  try {
    d.LoadRgb(0, 640, 480);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("32x24, expected 640x480"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(d.frame(0).rgb_path), std::string::npos);
  }
  EXPECT_THROW(d.LoadDepth(0, 640, 480), InputError);
  // A depth image where rgb is expected and vice versa; an 8-bit depth; a corrupt file.
  fs::copy_file(d.frame(1).depth_path, d.frame(1).rgb_path, fs::copy_options::overwrite_existing);
  EXPECT_THROW(d.LoadRgb(1), InputError);
  cv::imwrite(d.frame(2).depth_path, cv::Mat(24, 32, CV_8UC1, cv::Scalar(3)));
  try {
    d.LoadDepth(2);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("must be 16-bit 1-channel"), std::string::npos)
        << e.what();
  }
  WriteText(d.frame(3).rgb_path, "not a png");
  try {
    d.LoadRgb(3);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cannot decode"), std::string::npos) << e.what();
  }
  fs::remove(d.frame(0).depth_path);
  EXPECT_THROW(d.LoadDepth(0), InputError);
}

TEST_F(SmallDataset, AssociationsFile) {
  WriteText(dir_ / "associations.txt",
            "100.100000 rgb/100.100000.png 100.105000 depth/100.105000.png\n"
            "100.166000 rgb/100.166000.png 100.171000 depth/100.171000.png\n");
  RgbdDataset d = RgbdDataset::Open(dir_.string());
  EXPECT_EQ(d.size(), 2u);
  EXPECT_EQ(d.num_rgb_entries(), 4u);
  EXPECT_EQ(d.FrameForRgbEntry(2), 1u);
  EXPECT_FALSE(d.FrameForRgbEntry(1).has_value());
  DatasetOptions no_assoc;
  no_assoc.use_associations_file = false;
  EXPECT_EQ(RgbdDataset::Open(dir_.string(), no_assoc).size(), 4u);
  WriteText(dir_ / "associations.txt", "100.100000 rgb/100.100000.png 100.105000\n");
  ExpectError("associations.txt:1", "expected 4 columns");
  WriteText(dir_ / "associations.txt",
            "100.100000 rgb/100.100000.png 100.205000 depth/100.105000.png\n");
  ExpectError("associations.txt:1", "max_time_difference");
}

TEST_F(SmallDataset, InvalidOptions) {
  DatasetOptions o;
  o.max_time_difference = -1;
  EXPECT_THROW(RgbdDataset::Open(dir_.string(), o), InvalidOptions);
}

TEST(RealDataset, BonnCrowdPart) {
  DYGSLAM_REQUIRE_DATASET(dir, "bonn_crowd_part");
  const RgbdDataset d = RgbdDataset::Open(dir);
  EXPECT_EQ(d.num_rgb_entries(), 360u);
  // Every rgb entry has a depth partner within 17 ms (checked independently with numpy).
  EXPECT_EQ(d.size(), 360u);
  EXPECT_TRUE(d.has_groundtruth());
  std::set<std::string> depth_paths;
  for (size_t i = 0; i < d.size(); ++i) {
    EXPECT_LT(std::abs(SecondsBetween(d.frame(i).rgb_stamp, d.frame(i).depth_stamp)), 0.02);
    if (i > 0) {
      EXPECT_LT(d.frame(i - 1).rgb_stamp, d.frame(i).rgb_stamp);
    }
    EXPECT_TRUE(depth_paths.insert(d.frame(i).depth_path).second) << "depth used twice";
  }
  const cv::Mat rgb = d.LoadRgb(0, 640, 480);
  const cv::Mat depth = d.LoadDepth(d.size() - 1, 640, 480);
  EXPECT_EQ(rgb.type(), CV_8UC3);
  EXPECT_EQ(depth.type(), CV_16UC1);
  EXPECT_GT(cv::countNonZero(depth), 640 * 480 / 2);
  EXPECT_THROW(d.LoadRgb(0, 320, 240), InputError);
}

}  // namespace
}  // namespace dygslam
