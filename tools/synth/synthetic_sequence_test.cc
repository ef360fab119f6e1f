#include "tools/synth/synthetic_sequence.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/io/dataset.h"
#include "core/io/trajectory_io.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {

namespace fs = std::filesystem;

SyntheticOptions TinyOptions(uint64_t seed = 21) {
  SyntheticOptions options;
  options.camera.width = 160;
  options.camera.height = 120;
  options.camera.fx = options.camera.fy = 131.25;
  options.camera.cx = 79.5;
  options.camera.cy = 59.5;
  options.num_frames = 6;
  options.num_moving_objects = 2;
  options.seed = seed;
  options.texels_per_metre = 100;
  options.depth_noise = true;
  options.min_detection_pixels = 20;
  return options;
}

std::string ReadAll(const fs::path& path) {
  std::ifstream file(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(file), {});
}

// Data lines (no '#' comments) of a text file, split on whitespace.
std::vector<std::vector<std::string>> DataLines(const fs::path& path) {
  std::vector<std::vector<std::string>> lines;
  std::ifstream file(path);
  std::string line;
  while (std::getline(file, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream tokens(line);
    std::vector<std::string> fields;
    for (std::string t; tokens >> t;) fields.push_back(t);
    lines.push_back(fields);
  }
  return lines;
}

TEST(SyntheticSequence, WritesTheTumLayoutByteIdenticallyForOneSeed) {
  const std::string a = testing::MakeTempDir("synth_a");
  const std::string b = testing::MakeTempDir("synth_b");
  int calls = 0;
  WriteSyntheticSequence(a, TinyOptions(), [&](int done, int total) {
    EXPECT_EQ(done, ++calls);
    EXPECT_EQ(total, 6);
  });
  EXPECT_EQ(calls, 6);
  WriteSyntheticSequence(b, TinyOptions());
  std::vector<std::string> files;
  for (const auto& entry : fs::recursive_directory_iterator(a)) {
    if (entry.is_regular_file()) files.push_back(fs::relative(entry.path(), a).string());
  }
  EXPECT_EQ(files.size(), 7u + 3u * 6u);
  for (const std::string& name : files) {
    EXPECT_EQ(name.find(".tmp"), std::string::npos) << name;
    ASSERT_TRUE(fs::exists(fs::path(b) / name)) << name;
    EXPECT_EQ(ReadAll(fs::path(a) / name), ReadAll(fs::path(b) / name)) << name;
  }
  for (const char* name : {"rgb.txt", "depth.txt", "mask.txt", "groundtruth.txt", "detections.txt",
                           "objects.txt", "camera.yaml"}) {
    EXPECT_TRUE(fs::exists(fs::path(a) / name)) << name;
  }
  // Another seed gives other images.
  const std::string c = testing::MakeTempDir("synth_c");
  WriteSyntheticSequence(c, TinyOptions(22));
  const auto rgb_a = DataLines(fs::path(a) / "rgb.txt");
  EXPECT_NE(ReadAll(fs::path(a) / rgb_a[0][1]), ReadAll(fs::path(c) / rgb_a[0][1]));
}

TEST(SyntheticSequence, FilesMatchTheRenderedFrames) {
  const std::string dir = testing::MakeTempDir("synth_files");
  const SyntheticOptions options = TinyOptions();
  WriteSyntheticSequence(dir, options);
  const SyntheticScene scene(options);
  const auto rgb = DataLines(fs::path(dir) / "rgb.txt");
  const auto depth = DataLines(fs::path(dir) / "depth.txt");
  const auto mask = DataLines(fs::path(dir) / "mask.txt");
  const auto gt = DataLines(fs::path(dir) / "groundtruth.txt");
  const auto detections = DataLines(fs::path(dir) / "detections.txt");
  const auto objects = DataLines(fs::path(dir) / "objects.txt");
  ASSERT_EQ(rgb.size(), 6u);
  ASSERT_EQ(depth.size(), 6u);
  ASSERT_EQ(mask.size(), 6u);
  ASSERT_EQ(gt.size(), 6u);
  EXPECT_EQ(objects.size(), 12u);
  size_t detection_line = 0;
  for (int i = 0; i < 6; ++i) {
    const SyntheticFrame f = scene.RenderFrame(i);
    EXPECT_EQ(rgb[i][0], f.stamp.ToString());
    EXPECT_EQ(mask[i][0], f.stamp.ToString());
    EXPECT_EQ(depth[i][0], f.depth_stamp.ToString());
    const double offset = SecondsBetween(f.stamp, f.depth_stamp);
    EXPECT_GE(offset, 0.003 - 1e-9);
    EXPECT_LE(offset, 0.005 + 1e-9);
    const cv::Mat rgb_image =
        cv::imread((fs::path(dir) / rgb[i][1]).string(), cv::IMREAD_UNCHANGED);
    const cv::Mat depth_image =
        cv::imread((fs::path(dir) / depth[i][1]).string(), cv::IMREAD_UNCHANGED);
    const cv::Mat mask_image =
        cv::imread((fs::path(dir) / mask[i][1]).string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(rgb_image.type(), CV_8UC3);
    ASSERT_EQ(depth_image.type(), CV_16UC1);
    ASSERT_EQ(mask_image.type(), CV_8UC1);
    EXPECT_EQ(cv::norm(rgb_image, f.rgb, cv::NORM_INF), 0);
    EXPECT_EQ(cv::norm(depth_image, f.depth, cv::NORM_INF), 0);
    EXPECT_EQ(cv::norm(mask_image, f.dynamic_mask, cv::NORM_INF), 0);
    ASSERT_EQ(gt[i].size(), 8u);
    EXPECT_EQ(gt[i][0], f.stamp.ToString());
    for (int k = 0; k < 3; ++k)
      EXPECT_NEAR(std::stod(gt[i][1 + k]), f.world_from_cam.translation[k], 1e-6);
    for (const Detection& d : f.boxes) {
      ASSERT_LT(detection_line, detections.size());
      const auto& line = detections[detection_line++];
      ASSERT_EQ(line.size(), 7u);
      EXPECT_EQ(line[0], f.stamp.ToString());
      EXPECT_FLOAT_EQ(std::stof(line[1]), d.box.x);
      EXPECT_FLOAT_EQ(std::stof(line[4]), d.box.height);
      EXPECT_EQ(line[5], "0");
    }
    for (int k = 0; k < 2; ++k) {
      const auto& line = objects[2 * i + k];
      ASSERT_EQ(line.size(), 12u);
      EXPECT_EQ(line[1], std::to_string(k));
      const OrientedBox box = scene.MovingObjectBox(k, i);
      EXPECT_NEAR(std::stod(line[3]), box.world_from_box.translation.y(), 1e-6);
      EXPECT_NEAR(std::stod(line[11]), 1.7, 1e-9);
    }
  }
  EXPECT_EQ(detection_line, detections.size());
  const std::string yaml = ReadAll(fs::path(dir) / "camera.yaml");
  for (const char* key :
       {"Camera.fx: 131.25", "Camera.cx: 79.5", "Camera.width: 160", "Camera.bf: 40", "ThDepth: 40",
        "DepthMapFactor: 5000", "ORBextractor.nFeatures: 1000", "ORBextractor.scaleFactor: 1.2",
        "ORBextractor.nLevels: 8", "ORBextractor.iniThFAST: 20", "ORBextractor.minThFAST: 7",
        "Camera.k3: 0"}) {
    EXPECT_NE(yaml.find(key), std::string::npos) << key;
  }
}

TEST(SyntheticSequence, UnwritableDirectoryIsNamed) {
  const std::string dir = testing::MakeTempDir("synth_bad");
  const std::string blocker = (fs::path(dir) / "file").string();
  std::ofstream(blocker) << "x";
  try {
    WriteSyntheticSequence(blocker + "/sub", TinyOptions());
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(blocker), std::string::npos) << e.what();
  }
}

TEST(SyntheticSequence, LoadsThroughTheDatasetReader) {
  const std::string dir = testing::MakeTempDir("synth_io");
  const SyntheticOptions options = TinyOptions();
  WriteSyntheticSequence(dir, options);
  const RgbdDataset dataset = RgbdDataset::Open(dir);
  const SyntheticScene scene(options);
  ASSERT_EQ(dataset.size(), 6u);
  ASSERT_TRUE(dataset.has_groundtruth());
  for (size_t i = 0; i < dataset.size(); ++i) {
    const SyntheticFrame f = scene.RenderFrame(static_cast<int>(i));
    EXPECT_EQ(dataset.frame(i).rgb_stamp, f.stamp);
    EXPECT_EQ(dataset.frame(i).depth_stamp, f.depth_stamp);
    EXPECT_EQ(cv::norm(dataset.LoadRgb(i, 160, 120), f.rgb, cv::NORM_INF), 0);
    EXPECT_EQ(cv::norm(dataset.LoadDepth(i, 160, 120), f.depth, cv::NORM_INF), 0);
  }
  const std::vector<StampedPose> poses = ReadTumTrajectory(dataset.groundtruth_path());
  ASSERT_EQ(poses.size(), 6u);
  for (size_t i = 0; i < poses.size(); ++i) {
    const Rigid3d expected = scene.WorldFromCam(static_cast<int>(i));
    EXPECT_EQ(poses[i].stamp, scene.FrameStamp(static_cast<int>(i)));
    EXPECT_LT((poses[i].world_from_cam.translation - expected.translation).norm(), 2e-6);
    EXPECT_LT(RotationAngle(poses[i].world_from_cam.rotation.conjugate() * expected.rotation),
              1e-6);
  }
}

}  // namespace
}  // namespace dygslam
