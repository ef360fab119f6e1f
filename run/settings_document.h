// Every settings key dygslam knows, with its default, made from the code: the known-key list
// (KnownSettingsKeys) and the defaults the readers of a run leave in the options structs when a
// key is absent (SettingDefaultsRecorder). `dygslam settings` prints it; docs/settings.md holds
// the Markdown form, and the test docs/SettingsDocumentIsCurrent fails when the two differ.
#pragma once

#include <string>
#include <vector>

namespace dygslam {

struct SettingEntry {
  std::string key;            // fully dotted ("Camera.fx"); "Viewer.*" for a whole section
  std::string default_value;  // as a settings file writes it; "required" for required keys
  bool required = false;
  bool ignored = false;  // an ORB-SLAM2 key accepted and not used
  bool literal = false;  // default_value is a value as written in a file (not a description)
};

// In the order of KnownSettingsKeys(), grouped by section (root keys with Camera).
std::vector<SettingEntry> SettingEntries();

// "key: default" lines (`dygslam settings`).
std::string SettingsText();
// One Markdown table per section (`dygslam settings --markdown`).
std::string SettingsMarkdown();

}  // namespace dygslam
