// SystemOptions from a settings file: ORB-SLAM2 keys plus the optional sections
// Tracking.*, LocalMapping.*, DynamicFilter.*, Detector.* (inline defaults in each options struct).
#pragma once

#include "core/config/settings.h"
#include "core/system/system.h"

namespace dygslam {

SystemOptions SystemOptionsFromSettings(const Settings& settings);

}  // namespace dygslam
