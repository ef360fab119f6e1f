// Upper bounds of settings values that the options' own Check() leaves open (finite, >= 0, ...):
// given 1e20, such a key would otherwise take it without a word (DynamicFilter.C1,
// DynamicFilter.fundamental_threshold: every point consistent, LoopClosing.revisit_min_path_m,
// ...). The bounds are far beyond any useful value (pixels: the
// largest image side; metres: a kilometre or more): only absurd values are refused.
#pragma once

#include <sstream>
#include <string>

#include "core/config/config_reader.h"

namespace dygslam {

// Fails (InputError "<file>:<line>: key '<section.key>': ...") when `key` is in the file and
// `value` (as read) is above `max`; `unit` follows the bound in the message ("px", "m", "").
inline void CheckSettingAtMost(const ConfigReader& section, const std::string& key, double value,
                               double max, const std::string& unit) {
  if (!section.Has(key) || value <= max) return;
  std::ostringstream message;
  message << "implausible value " << value << " (expected at most " << max
          << (unit.empty() ? "" : " ") << unit << ")";
  section.Fail(key, message.str());
}

}  // namespace dygslam
