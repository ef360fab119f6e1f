// Local-mapping schedule settings: the waits of tracking for local mapping and the
// final bundle adjustment are read, default off, and bad values are named; so are the weak-frame
// keyframe rule and the fallback smoothing weight.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "core/base/error.h"
#include "core/config/settings.h"
#include "core/dynamic/yolo_detector.h"
#include "run/system_config.h"
#include "tests/support/settings_text.h"

namespace dygslam {
namespace {

std::string PresetPath(const std::string& name) {
  const char* src = std::getenv("DYGSLAM_SOURCE_DIR");
  return std::string(src ? src : ".") + "/config/" + name + ".yaml";
}

std::string ReadText(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

SystemOptions Options(const std::string& section) {
  const std::string path = PresetPath("bonn");
  // The preset's own Tracking: section (the dataset-run hand-off wait) left out: the cases
  // bring theirs, and the code's defaults are what "" checks.
  return SystemOptionsFromSettings(
      ParseSettings(testing::WithoutSection(ReadText(path), "Tracking") + "\n" + section, path));
}

void ExpectNamed(const std::string& section, const std::string& field) {
  try {
    Options(section);
    ADD_FAILURE() << "expected InputError for " << section;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
  }
}

TEST(ScheduleConfig, WaitsAndFinalBundleAdjustmentAreReadAndChecked) {
  const SystemOptions defaults = Options("");
  EXPECT_EQ(defaults.tracking.keyframe_wait_ms, 0);
  EXPECT_EQ(defaults.tracking.handoff_wait_ms, 0);
  EXPECT_EQ(defaults.local_mapping.final_ba_iterations, 0);
  const SystemOptions set = Options(
      "Tracking:\n  keyframe_wait_ms: 50\n  handoff_wait_ms: 20.5\n"
      "LocalMapping:\n  final_ba_iterations: 10\n");
  EXPECT_EQ(set.tracking.keyframe_wait_ms, 50);
  EXPECT_EQ(set.tracking.handoff_wait_ms, 20.5);
  EXPECT_EQ(set.local_mapping.final_ba_iterations, 10);
  ExpectNamed("Tracking:\n  keyframe_wait_ms: -1\n", "Tracking.keyframe_wait_ms");
  ExpectNamed("Tracking:\n  handoff_wait_ms: 20000\n", "Tracking.handoff_wait_ms");
  ExpectNamed("LocalMapping:\n  final_ba_iterations: -3\n", "LocalMapping.final_ba_iterations");
}

// The dataset presets wait for local mapping after each keyframe (threaded runs give
// the deterministic trajectory; docs/how_it_works.md, "Hand-off wait"); the options struct's default, what a
// settings file of one's own gets, stays 0 (live use).
TEST(ScheduleConfig, DatasetPresetsSetTheHandOffWait) {
  for (const char* name : {"bonn", "tum1", "tum2", "tum3"}) {
    const std::string path = PresetPath(name);
    const SystemOptions preset = SystemOptionsFromSettings(ParseSettings(ReadText(path), path));
    EXPECT_EQ(preset.tracking.handoff_wait_ms, 1000) << path;
    EXPECT_EQ(preset.tracking.keyframe_wait_ms, 0) << path;
  }
  EXPECT_EQ(TrackingOptions{}.handoff_wait_ms, 0);
}

// The presets run the detector as the paper does (every frame, square
// 320 x 320 input); a settings file without these keys gets the live defaults (every 2nd frame,
// the frame's aspect ratio, one OpenCV thread), docs/dds_components.md "Live use on a robot".
TEST(ScheduleConfig, DatasetPresetsDetectEveryFrameAtTheSquareInputLiveDefaultsDoNot) {
  for (const char* name : {"bonn", "tum1", "tum2", "tum3"}) {
    const std::string path = PresetPath(name);
    const SystemOptions preset = SystemOptionsFromSettings(ParseSettings(ReadText(path), path));
    EXPECT_EQ(preset.detection_every_n_frames, 1) << path;
    EXPECT_EQ(preset.detector.input_width, 320) << path;
    EXPECT_EQ(preset.detector.input_height, 320) << path;
    EXPECT_EQ(preset.detector.num_threads, 1) << path;
  }
  // bonn.yaml without its dataset-run keys: the camera and ORB settings of a live run.
  const std::string path = PresetPath("bonn");
  std::string text;
  std::istringstream lines(testing::WithoutSection(ReadText(path), "Tracking"));
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("Detector.every_n_frames:", 0) == 0 ||
        line.rfind("Detector.input_height:", 0) == 0)
      continue;
    text += line + "\n";
  }
  const SystemOptions live = SystemOptionsFromSettings(ParseSettings(text, path));
  EXPECT_EQ(live.detection_every_n_frames, 2);
  EXPECT_EQ(live.detector.input_height, 0);
  EXPECT_EQ(DetectorInputSize(live.detector, {640, 480}), cv::Size(live.detector.input_width, 256));
  EXPECT_EQ(live.detector.num_threads, 1);
  EXPECT_EQ(live.tracking.handoff_wait_ms, 0);
}

TEST(ScheduleConfig, WeakFrameKeyframeRuleAndSmoothingWeightAreReadAndChecked) {
  const SystemOptions defaults = Options("");
  EXPECT_EQ(defaults.tracking.keyframe_weak_inliers, TrackingOptions{}.keyframe_weak_inliers);
  EXPECT_EQ(defaults.tracking.fallback_smoothing_dense_weight,
            TrackingOptions{}.fallback_smoothing_dense_weight);
  const SystemOptions set =
      Options("Tracking:\n  keyframe_weak_inliers: 0\n  fallback_smoothing_dense_weight: 0.2\n");
  EXPECT_EQ(set.tracking.keyframe_weak_inliers, 0);
  EXPECT_EQ(set.tracking.fallback_smoothing_dense_weight, 0.2);
  ExpectNamed("Tracking:\n  keyframe_weak_inliers: -1\n", "Tracking.keyframe_weak_inliers");
  ExpectNamed("Tracking:\n  fallback_smoothing_dense_weight: 1.5\n",
              "Tracking.fallback_smoothing_dense_weight");
}

}  // namespace
}  // namespace dygslam
