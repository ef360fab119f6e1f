// Settings file -> the options of a run, written once: every command that runs the
// SLAM (run, map, bench, component, bridge --run-slam, the soak benchmark) reads its settings
// through LoadRunConfiguration.
//
//   RunConfiguration c = LoadRunConfiguration({path, read_options, "full", deterministic});
//   System system(c.system);  KeyframeMapper mapper(c.system.camera, c.octomap);
#pragma once

#include <string>

#include "core/config/settings.h"
#include "core/system/system.h"
#include "mapping/octomap_builder.h"

namespace dygslam {

struct RunSettingsRequest {
  std::string settings_path;  // ORB-SLAM2-style YAML (+ dygslam's sections)
  SettingsReadOptions read;   // unknown keys: warning or error
  // A named filter configuration (ApplyFilterConfiguration: none, boxes, geometry, paper,
  // paper+margin, paper+margin+demotion, full).
  std::string filter = "full";
  // Fixed seeds, synchronous local mapping and one detector thread (bit-identical detections in
  // every mode): identical output run to run.
  bool deterministic = false;
};

struct RunConfiguration {
  Settings settings;  // the file as read (sections other modules read themselves)
  SystemOptions system;
  OctoMapOptions octomap;  // the OctoMap: section
};

// Throws InputError naming the file, line and key for a bad settings file, InvalidOptions for an
// unknown filter name.
RunConfiguration LoadRunConfiguration(const RunSettingsRequest& request);

// options->deterministic and what it implies (one detector thread).
void MakeDeterministic(SystemOptions* options);

// The internal detector's model files, resolved before a command writes anything: when the
// filter needs person boxes and no model was given (the default model, otherwise resolved on the
// first frame), the default model's files are looked up now, so that missing models are an
// InputError before any output exists, not after empty outputs were written. Same files as the
// System would resolve (only num_threads of the defaults kept, as System does).
void ResolveDetectorModel(SystemOptions* options);

}  // namespace dygslam
