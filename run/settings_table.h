// Every settings key dygslam knows, in one list made from the tables of the sections: ORB-SLAM2's
// keys (core/config/settings.h), the system's sections (run/system_config.h) and the map's
// (mapping/octomap_settings.h). Reading a settings file checks its keys against it.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "core/config/setting_table.h"
#include "core/config/settings.h"

namespace dygslam {

// Every key, in table order: ORB-SLAM2's, the ones accepted and not used (Camera.RGB, Viewer.*),
// Tracking, LocalMapping, LoopClosing, DynamicFilter, Detector, OctoMap.
const std::vector<std::string>& KnownSettingsKeys();

// Keys that were settings once, with why they are not: a file that still sets one gets that
// reason (a warning, or an error where unknown keys are errors) instead of "unknown key".
const std::vector<std::pair<std::string, std::string>>& RetiredSettingsKeys();

// Every key with its default (what a file holding only the required keys leaves), range and doc.
std::vector<SettingDoc> SettingDocs();

// Reads a settings file: unknown keys first (a warning naming file:line and the closest known key,
// or with UnknownKeyPolicy::kError an InputError), then ORB-SLAM2's keys (ReadCameraSettings).
// Throws InputError naming the file, line and key.
Settings LoadSettings(const std::string& path, const SettingsReadOptions& read_options = {});
// Same from YAML text (`name` stands in for the file name in messages).
Settings ParseSettings(const std::string& text, const std::string& name,
                       const SettingsReadOptions& read_options = {UnknownKeyPolicy::kWarn, false});

}  // namespace dygslam
