// Schedule settings: the local BA's lag and the final bundle adjustment are read and bad values
// are named; so are the weak-frame keyframe rule and the fallback smoothing weight. The dataset
// presets hold the sensor only: a dataset run gets the schedule a robot gets.
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

TEST(ScheduleConfig, BaLagAndFinalBundleAdjustmentAreReadAndChecked) {
  const SystemOptions defaults = Options("");
  EXPECT_EQ(defaults.local_mapping.ba_lag_frames, LocalMappingOptions{}.ba_lag_frames);
  EXPECT_EQ(defaults.local_mapping.final_ba_iterations, 0);
  const SystemOptions set =
      Options("LocalMapping:\n  ba_lag_frames: 4\n  final_ba_iterations: 10\n");
  EXPECT_EQ(set.local_mapping.ba_lag_frames, 4);
  EXPECT_EQ(set.local_mapping.final_ba_iterations, 10);
  ExpectNamed("LocalMapping:\n  ba_lag_frames: -1\n", "LocalMapping.ba_lag_frames");
  ExpectNamed("LocalMapping:\n  ba_lag_frames: 31\n", "LocalMapping.ba_lag_frames");
  ExpectNamed("LocalMapping:\n  final_ba_iterations: -3\n", "LocalMapping.final_ba_iterations");
}


// Each preset sets camera, depth and ORB keys only, so `dygslam run` on a dataset runs the
// schedule and detector cadence a robot runs (the shipped defaults).
TEST(ScheduleConfig, DatasetPresetsHoldTheSensorOnly) {
  const SystemOptions defaults = Options("");
  for (const char* name : {"bonn", "tum1", "tum2", "tum3"}) {
    const std::string path = PresetPath(name);
    std::istringstream lines(ReadText(path));
    for (std::string line; std::getline(lines, line);) {
      if (line.empty() || line[0] == '#' || line[0] == '%' || line[0] == ' ') continue;
      const std::string key = line.substr(0, line.find(':'));
      const bool sensor = key.rfind("Camera.", 0) == 0 || key.rfind("ORBextractor.", 0) == 0 ||
                          key == "ThDepth" || key == "DepthMapFactor";
      EXPECT_TRUE(sensor) << path << ": " << key << " is not a sensor key";
    }
    const SystemOptions preset = SystemOptionsFromSettings(ParseSettings(ReadText(path), path));
    EXPECT_EQ(preset.detection_every_n_frames, defaults.detection_every_n_frames) << path;
    EXPECT_EQ(preset.detector.input_height, defaults.detector.input_height) << path;
    EXPECT_EQ(preset.local_mapping.ba_lag_frames, defaults.local_mapping.ba_lag_frames) << path;
  }
}

TEST(ScheduleConfig, SmoothingWeightIsReadAndChecked) {
  const SystemOptions defaults = Options("");
  EXPECT_EQ(defaults.tracking.fallback_smoothing_dense_weight,
            TrackingOptions{}.fallback_smoothing_dense_weight);
  const SystemOptions set =
      Options("Tracking:\n  fallback_smoothing_dense_weight: 0.2\n");
  EXPECT_EQ(set.tracking.fallback_smoothing_dense_weight, 0.2);
  ExpectNamed("Tracking:\n  fallback_smoothing_dense_weight: 1.5\n",
              "Tracking.fallback_smoothing_dense_weight");
}

}  // namespace
}  // namespace dygslam
