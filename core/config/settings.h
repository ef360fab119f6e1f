// The settings file of a run: ORB-SLAM2's RGB-D YAML keys (Camera.*, ThDepth, DepthMapFactor,
// ORBextractor.*). Modules add their own sections through `reader` (see config_reader.h).
#pragma once

#include <string>

#include "core/base/camera.h"
#include "core/config/config_reader.h"
#include "core/slam/orb_extractor.h"

namespace dygslam {

struct Settings {
  PinholeCamera camera;
  RgbdSensorOptions sensor;
  OrbExtractorOptions orb;
  std::string path;     // the settings file
  ConfigReader reader;  // for module sections
};

// Reads ORB-SLAM2's keys:
//   required: Camera.fx, Camera.fy, Camera.cx, Camera.cy, Camera.k1, Camera.k2, Camera.p1,
//   Camera.p2 optional (default): Camera.k3 (0), Camera.width (640), Camera.height (480),
//   Camera.fps (30),
//     Camera.bf (40), ThDepth (40), DepthMapFactor (5000), ORBextractor.nFeatures (1000),
//     ORBextractor.scaleFactor (1.2), ORBextractor.nLevels (8), ORBextractor.iniThFAST (20),
//     ORBextractor.minThFAST (7)
// Keys ORB-SLAM2 has but dygslam does not use (Camera.RGB, Viewer.*) are ignored.
// Throws InputError naming the file, line and key (bad values, failed Check()).
Settings LoadSettings(const std::string& path);

// The settings file for a dataset folder: its own camera.yaml (generated sequences), else the
// preset of `config_dir` by folder name (freiburg1/2/3 -> tum1/2/3.yaml, otherwise bonn.yaml).
std::string DefaultSettingsPath(const std::string& dataset_dir, const std::string& config_dir);
// Same from YAML text (`name` stands in for the file name in messages).
Settings ParseSettings(const std::string& text, const std::string& name);

}  // namespace dygslam
