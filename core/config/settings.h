// The settings file of a run: ORB-SLAM2's RGB-D YAML keys (Camera.*, ThDepth, DepthMapFactor,
// ORBextractor.*). Modules add their own sections through `reader` (see config_reader.h).
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "core/base/camera.h"
#include "core/config/config_reader.h"
#include "core/config/setting_table.h"
#include "core/slam/feature/orb_extractor.h"

namespace dygslam {

struct Settings {
  PinholeCamera camera;
  RgbdSensorOptions sensor;
  OrbExtractorOptions orb;
  std::string path;     // the settings file
  ConfigReader reader;  // for module sections
  // "file:line: unknown key 'Camera.fxx' (did you mean 'Camera.fx'?)", one per unknown key
  // (LoadSettings has printed them as warnings unless they were made errors).
  std::vector<std::string> warnings;
};

// What to do with a key that no module reads (a misspelling would silently keep the default).
enum class UnknownKeyPolicy { kWarn, kError };
struct SettingsReadOptions {
  UnknownKeyPolicy unknown_keys = UnknownKeyPolicy::kWarn;
  // kWarn: print each warning to stderr (ParseSettings never prints).
  bool print_warnings = true;
};

// ORB-SLAM2's keys: Camera.* (fx, fy, cx, cy, k1, k2, p1, p2 required), ThDepth, DepthMapFactor,
// ORBextractor.*, with their ranges and defaults.
const SettingsTable<Settings>& CameraSettingsTable();
// ORB-SLAM2 / ORB-SLAM3 keys accepted and not used (Camera.RGB, Viewer.*: every key below Viewer).
const std::vector<std::string>& IgnoredSettingsKeys();

// Reads ORB-SLAM2's keys (CameraSettingsTable) from `reader` and checks them for plausibility:
// focal lengths 0.05..100 times the larger image side, principal point inside the image,
// |k1|, |k2|, |k3| <= 10, |p1|, |p2| <= 1, and when Camera.bf is given a baseline bf / fx of at
// most 1 m. Keys of other sections are left to their readers; which keys are unknown only the run
// layer, which knows every section, can tell (run/settings_table.h: LoadSettings).
// Throws InputError naming the file, line and key.
Settings ReadCameraSettings(ConfigReader reader);

// The keys of settings->reader that are not in `known`: a warning each (in settings->warnings,
// printed unless read_options says not to) naming file:line and the closest known key, or with
// UnknownKeyPolicy::kError an InputError. A key of `retired` gets its reason instead.
void CheckUnknownSettingsKeys(const std::vector<std::string>& known,
                              const std::vector<std::pair<std::string, std::string>>& retired,
                              const SettingsReadOptions& read_options, Settings* settings);

// The settings file for a dataset folder: its own camera.yaml (generated sequences), else the
// preset of `config_dir` by folder name (freiburg1/2/3 -> tum1/2/3.yaml, otherwise bonn.yaml).
std::string DefaultSettingsPath(const std::string& dataset_dir, const std::string& config_dir);

}  // namespace dygslam
