// Sequences for `dygslam bench`: every TUM RGB-D / Bonn RGB-D Dynamic folder (rgb.txt + depth.txt
// + groundtruth.txt) found in a data directory, with the settings file each one runs with.
#pragma once

#include <string>
#include <vector>

#include "core/config/settings.h"

namespace dygslam {

struct BenchSequence {
  std::string name;  // folder name, e.g. "bonn_crowd_part", "rgbd_dataset_freiburg3_walking_xyz"
  std::string directory;      // absolute
  std::string settings_path;  // settings YAML the sequence runs with
};

// The settings file for a dataset folder: <dir>/camera.yaml when present (generated sequences),
// else a preset of `config_dir` chosen by the folder name: "freiburg1" -> tum1.yaml, "freiburg2"
// -> tum2.yaml, "freiburg3" -> tum3.yaml, anything else (Bonn) -> bonn.yaml.
// DefaultSettingsPath: core/config/settings.h

// `data_dir` itself when it is a sequence folder, else its sub-folders up to `max_depth` levels
// deep that are, sorted by name. Folders with rgb.txt and depth.txt but no groundtruth.txt cannot
// be scored: they are listed in `skipped` (may be nullptr) with the reason. Throws InputError
// when `data_dir` is not a directory. `settings_override` non-empty: every sequence uses it.
std::vector<BenchSequence> FindBenchSequences(const std::string& data_dir,
                                              const std::string& config_dir,
                                              const std::string& settings_override = "",
                                              std::vector<std::string>* skipped = nullptr,
                                              int max_depth = 2);

}  // namespace dygslam
