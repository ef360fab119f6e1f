// SystemOptions from a settings file: ORB-SLAM2 keys plus the optional sections Tracking.*,
// LocalMapping.*, LoopClosing.*, DynamicFilter.*, Detector.* (defaults in each options struct).
#pragma once

#include "core/config/settings.h"
#include "core/system/system.h"

namespace dygslam {

// The keys of the sections Tracking, LocalMapping, LoopClosing, DynamicFilter and Detector.
const SettingsTable<SystemOptions>& SystemSettingsTable();

// The options of `settings` (its camera, sensor and ORB values) with the keys of
// SystemSettingsTable() read from its file. Throws InputError naming the file, line and key.
SystemOptions SystemOptionsFromSettings(const Settings& settings);

}  // namespace dygslam
