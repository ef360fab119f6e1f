// Schedule settings: the local BA's lag is read and bad values are named; keys that are no longer
// settings are named with their reason. The dataset presets hold the sensor only: a dataset run
// gets the schedule a robot gets.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "core/base/error.h"
#include "core/config/settings.h"
#include "core/dynamic/yolo_detector.h"
#include "run/settings_table.h"
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

// A file that still sets a key that is no longer a setting is told so, with the reason and the
// line: a warning by default, an error where unknown keys are errors (--strict-settings).
TEST(ScheduleConfig, RetiredKeysAreNamedWithTheirReason) {
  const std::string path = PresetPath("bonn");
  const std::string base = testing::WithoutSection(ReadText(path), "Tracking") + "\n";
  for (const auto& [key, reason] : RetiredSettingsKeys()) {
    const std::string text = base + key + ": 1\n";
    const Settings s = ParseSettings(text, path);
    ASSERT_EQ(s.warnings.size(), 1u) << key;
    EXPECT_NE(s.warnings[0].find("key '" + key + "' is no longer a setting (" + reason + ")"),
              std::string::npos)
        << s.warnings[0];
    EXPECT_EQ(s.warnings[0].find("unknown key"), std::string::npos) << s.warnings[0];
    try {
      ParseSettings(text, path, {UnknownKeyPolicy::kError, false});
      ADD_FAILURE() << "expected InputError for " << key;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("no longer a setting"), std::string::npos) << e.what();
    }
  }
  // A key never known is still "unknown".
  const Settings unknown = ParseSettings(base + "LocalMapping.no_such_key: 1\n", path);
  ASSERT_EQ(unknown.warnings.size(), 1u);
  EXPECT_NE(unknown.warnings[0].find("unknown key"), std::string::npos) << unknown.warnings[0];
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

}  // namespace
}  // namespace dygslam
