// The settings document: every key with its default, range and one line on what it does, made
// from the settings tables (run/settings_table.h). `dygslam settings` prints it; docs/settings.md
// holds the Markdown form, and the test docs/SettingsDocumentIsCurrent fails when the two differ.
#pragma once

#include <string>

namespace dygslam {

// "key: default" lines (`dygslam settings`).
std::string SettingsText();
// One Markdown table per section (root keys with Camera), then the keys no longer read
// (`dygslam settings --markdown`).
std::string SettingsMarkdown();

}  // namespace dygslam
