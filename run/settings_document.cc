#include "run/settings_document.h"

#include <map>
#include <set>

#include "core/config/setting_defaults.h"
#include "core/config/settings.h"
#include "core/dynamic/dynamic_filter.h"
#include "core/dynamic/yolo_detector.h"
#include "mapping/octomap_builder.h"
#include "run/mapping_config.h"
#include "run/system_config.h"

namespace dygslam {
namespace {

// The required keys only: everything else keeps its default while the readers run.
constexpr const char* kRequiredOnly =
    "Camera.fx: 500\nCamera.fy: 500\nCamera.cx: 319.5\nCamera.cy: 239.5\n"
    "Camera.k1: 0\nCamera.k2: 0\nCamera.p1: 0\nCamera.p2: 0\n";

std::string Section(const std::string& key) {
  const size_t dot = key.find('.');
  return dot == std::string::npos ? "Camera" : key.substr(0, dot);
}

// Defaults that are not a field's plain value: derived from another key, resolved from a file or
// the environment, or read into a local first.
std::map<std::string, std::string> DerivedDefaults() {
  std::string classes = "[";
  const DetectorOptions detector;
  for (size_t i = 0; i < detector.dynamic_classes.size(); ++i)
    classes += (i == 0 ? "" : ", ") + detector.dynamic_classes[i];
  classes += "]";
  return {
      {"Tracking.max_frames_between_keyframes", "Camera.fps"},
      {"LoopClosing.vocabulary",
       "$DYGSLAM_VOCABULARY, else vocabulary.dygvoc beside the settings file, else "
       "config/vocabulary.dygvoc"},
      {"DynamicFilter.mode", std::string(ToString(DynamicFilterOptions{}.mode)) + " (--filter)"},
      {"Detector.cfg", "the model's"},
      {"Detector.weights", "the model's"},
      {"Detector.names", "the model's"},
      {"Detector.dynamic_classes", classes},
  };
}

}  // namespace

std::vector<SettingEntry> SettingEntries() {
  std::map<std::string, std::string> recorded;
  {
    SettingDefaultsRecorder recorder;
    const Settings settings = ParseSettings(kRequiredOnly, "<defaults>");
    SystemOptionsFromSettings(settings);
    OctoMapOptions octomap;
    ReadOptions(settings.reader, &octomap);
    recorded = recorder.defaults();
  }
  const std::set<std::string> ignored = {"Camera.RGB", "Camera.type", "File.version", "Viewer.*"};
  const std::map<std::string, std::string> derived = DerivedDefaults();
  std::vector<std::string> sections;
  std::map<std::string, std::vector<SettingEntry>> by_section;
  for (const std::string& key : KnownSettingsKeys()) {
    SettingEntry e;
    e.key = key;
    if (ignored.count(key)) {
      e.ignored = true;
      e.default_value = "accepted, not used";
    } else if (auto d = derived.find(key); d != derived.end()) {
      e.default_value = d->second;
    } else if (auto r = recorded.find(key); r != recorded.end()) {
      e.default_value = r->second.empty() ? "\"\"" : r->second;
      e.literal = true;
    } else {
      e.required = true;
      e.default_value = "required";
    }
    const std::string section = Section(key);
    if (!by_section.count(section)) sections.push_back(section);
    by_section[section].push_back(e);
  }
  std::vector<SettingEntry> entries;
  for (const std::string& section : sections)
    for (const SettingEntry& e : by_section[section]) entries.push_back(e);
  return entries;
}

std::string SettingsText() {
  std::string text;
  for (const SettingEntry& e : SettingEntries()) text += e.key + ": " + e.default_value + "\n";
  return text;
}

std::string SettingsMarkdown() {
  std::string text;
  std::string section;
  for (const SettingEntry& e : SettingEntries()) {
    if (Section(e.key) != section) {
      section = Section(e.key);
      text += (text.empty() ? "" : "\n") + std::string("### ") + section + "\n\n";
      text += "| key | default |\n|---|---|\n";
    }
    text += "| `" + e.key + "` | " + (e.literal ? "`" + e.default_value + "`" : e.default_value) +
            " |\n";
  }
  text += "\n### Keys no longer read\n\n";
  text +=
      "A file that sets one gets this reason in a warning (an error with --strict-settings).\n\n";
  text += "| key | why |\n|---|---|\n";
  for (const auto& [key, reason] : RetiredSettingsKeys())
    text += "| `" + key + "` | " + reason + " |\n";
  return text;
}

}  // namespace dygslam
