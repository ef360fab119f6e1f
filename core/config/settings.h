// The settings file of a run: ORB-SLAM2's RGB-D YAML keys (Camera.*, ThDepth, DepthMapFactor,
// ORBextractor.*). Modules add their own sections through `reader` (see config_reader.h).
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "core/base/camera.h"
#include "core/config/config_reader.h"
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

// Every key dygslam reads (ORB-SLAM2's plus the module sections Tracking, LocalMapping,
// DynamicFilter, Detector, OctoMap) and ORB-SLAM2 keys it accepts without using (Camera.RGB,
// Viewer.*). A module that reads a new key adds it here.
const std::vector<std::string>& KnownSettingsKeys();
// Keys that were settings once, with why they are not: a file that still sets one gets that
// reason (a warning, or an error where unknown keys are errors) instead of "unknown key".
const std::vector<std::pair<std::string, std::string>>& RetiredSettingsKeys();

// Reads ORB-SLAM2's keys:
//   required: Camera.fx, Camera.fy, Camera.cx, Camera.cy, Camera.k1, Camera.k2, Camera.p1,
//   Camera.p2 optional (default): Camera.k3 (0), Camera.width (640), Camera.height (480),
//   Camera.fps (30),
//     Camera.bf (40), ThDepth (40), DepthMapFactor (5000), ORBextractor.nFeatures (1000),
//     ORBextractor.scaleFactor (1.2), ORBextractor.nLevels (8), ORBextractor.iniThFAST (20),
//     ORBextractor.minThFAST (7)
// Keys ORB-SLAM2 has but dygslam does not use (Camera.RGB, Viewer.*) are ignored.
// Plausible ranges (InputError otherwise): focal lengths 0.05..100 times the larger image side,
// principal point inside the image, |k1|, |k2|, |k3| <= 10, |p1|, |p2| <= 1, and when Camera.bf is
// given a baseline bf / fx above 0 and at most 1 m.
// Unknown keys: a warning (or, with UnknownKeyPolicy::kError, an InputError) naming file:line
// and the closest known key. A section given as a list is an error.
// Throws InputError naming the file, line and key (bad values, failed Check()).
Settings LoadSettings(const std::string& path, const SettingsReadOptions& read_options = {});

// The settings file for a dataset folder: its own camera.yaml (generated sequences), else the
// preset of `config_dir` by folder name (freiburg1/2/3 -> tum1/2/3.yaml, otherwise bonn.yaml).
std::string DefaultSettingsPath(const std::string& dataset_dir, const std::string& config_dir);
// Same from YAML text (`name` stands in for the file name in messages).
Settings ParseSettings(const std::string& text, const std::string& name,
                       const SettingsReadOptions& read_options = {UnknownKeyPolicy::kWarn, false});

}  // namespace dygslam
