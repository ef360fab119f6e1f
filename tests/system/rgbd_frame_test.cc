// System::FeedRgbdFrame takes the one frame type (core/base/rgbd_frame.h): on the real Bonn crowd
// frames, a frame with raw depth and its scale, the same depth given in metres, and the loose
// convenience overload give the same trajectory to the last bit (depth is converted once, the
// same way); detections given as an empty list mean "no boxes" (the System's detector never
// runs); a frame that cannot be used is an error naming the image.
#include <gtest/gtest.h>

#include <vector>

#include "core/base/error.h"
#include "core/config/settings.h"
#include "core/io/dataset.h"
#include "core/system/system.h"
#include "run/settings_table.h"
#include "run/system_config.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {

constexpr size_t kFrames = 40;

enum class Feed { kRawFrame, kMetresFrame, kLooseImages, kEmptyDetections };

SystemOptions Options(FilterMode mode) {
  const Settings settings =
      LoadSettings(std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/bonn.yaml");
  SystemOptions options = SystemOptionsFromSettings(settings);
  options.filter.mode = mode;
  options.deterministic = true;
  return options;
}

std::vector<FrameResult> RunFrames(const RgbdDataset& dataset, const SystemOptions& options,
                                   Feed how) {
  System system(options);
  std::vector<FrameResult> results;
  for (size_t i = 0; i < kFrames; ++i) {
    RgbdFrame frame;
    frame.stamp = dataset.frame(i).rgb_stamp;
    frame.rgb = dataset.LoadRgb(i);
    frame.depth = dataset.LoadDepth(i);
    frame.depth_scale = options.sensor.depth_map_factor;
    switch (how) {
      case Feed::kRawFrame:
        results.push_back(system.FeedRgbdFrame(frame));
        break;
      case Feed::kMetresFrame:
        frame.depth.convertTo(frame.depth, CV_32F, 1.0 / options.sensor.depth_map_factor);
        frame.depth_scale = 1.0;  // ignored for CV_32FC1
        results.push_back(system.FeedRgbdFrame(frame));
        break;
      case Feed::kLooseImages:
        results.push_back(system.FeedRgbdFrame(frame.rgb, frame.depth, frame.stamp));
        break;
      case Feed::kEmptyDetections:
        frame.detections.emplace();
        results.push_back(system.FeedRgbdFrame(frame));
        break;
    }
  }
  system.Shutdown();
  return results;
}

void ExpectSameTrajectory(const std::vector<FrameResult>& a, const std::vector<FrameResult>& b) {
  ASSERT_EQ(a.size(), b.size());
  int posed = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].state, b[i].state) << i;
    EXPECT_EQ(a[i].num_features, b[i].num_features) << i;
    EXPECT_EQ(a[i].num_tracked, b[i].num_tracked) << i;
    ASSERT_EQ(a[i].world_from_cam.has_value(), b[i].world_from_cam.has_value()) << i;
    if (!a[i].world_from_cam) continue;
    ++posed;
    EXPECT_EQ(a[i].world_from_cam->translation, b[i].world_from_cam->translation) << i;
    EXPECT_EQ(a[i].world_from_cam->rotation.coeffs(), b[i].world_from_cam->rotation.coeffs()) << i;
  }
  EXPECT_GE(posed, static_cast<int>(a.size()) - 2);  // the test means something: frames tracked
}

TEST(RgbdFrameFeed, RawMetresAndLooseImagesGiveTheSameTrajectory) {
  DYGSLAM_REQUIRE_DATASET(dir, "bonn_crowd_part");
  const RgbdDataset dataset = RgbdDataset::Open(dir);
  const SystemOptions options = Options(FilterMode::kGeometry);
  const std::vector<FrameResult> raw = RunFrames(dataset, options, Feed::kRawFrame);
  ExpectSameTrajectory(raw, RunFrames(dataset, options, Feed::kMetresFrame));
  ExpectSameTrajectory(raw, RunFrames(dataset, options, Feed::kLooseImages));
}

TEST(RgbdFrameFeed, EmptyDetectionsMeanNoBoxesAndNoDetector) {
  DYGSLAM_REQUIRE_DATASET(dir, "bonn_crowd_part");
  const RgbdDataset dataset = RgbdDataset::Open(dir);
  SystemOptions options = Options(FilterMode::kFull);
  options.detector.cfg_path = "/nonexistent/detector.cfg";  // would fail if it were loaded
  const std::vector<FrameResult> results = RunFrames(dataset, options, Feed::kEmptyDetections);
  ASSERT_EQ(results.size(), kFrames);
  for (const FrameResult& r : results) {
    EXPECT_TRUE(r.detections_used);
    EXPECT_FALSE(r.detections_carried);
    EXPECT_EQ(r.times.detection_ms, 0.0);
    EXPECT_TRUE(HasPose(r.state));
  }
}

TEST(RgbdFrameFeed, UnusableFrameIsAnErrorNamingTheImage) {
  DYGSLAM_REQUIRE_DATASET(dir, "bonn_crowd_part");
  const RgbdDataset dataset = RgbdDataset::Open(dir);
  System system(Options(FilterMode::kNone));
  RgbdFrame frame;
  frame.stamp = dataset.frame(0).rgb_stamp;
  frame.rgb = dataset.LoadRgb(0);
  frame.depth = dataset.LoadDepth(0);
  frame.depth_scale = 0;
  try {
    system.FeedRgbdFrame(frame);
    ADD_FAILURE() << "depth_scale 0 accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("depth image: depth_scale"), std::string::npos)
        << e.what();
  }
  frame.depth_scale = 5000;
  frame.mask = cv::Mat(10, 10, CV_8UC1);
  EXPECT_THROW(system.FeedRgbdFrame(frame), InputError);
  frame.mask = cv::Mat();
  EXPECT_TRUE(HasPose(system.FeedRgbdFrame(frame).state));  // a refused frame leaves no trace
}

}  // namespace
}  // namespace dygslam
