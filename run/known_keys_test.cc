// Every key the run layer reads is a known settings key: a key that works must not be warned
// about as "unknown" (KnownSettingsKeys() is a list of its own; it had drifted from the readers:
// Tracking.fallback_* and the local-mapping schedule keys were read but warned about).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "core/config/config_reader.h"
#include "core/config/settings.h"
#include "mapping/octomap_settings.h"
#include "run/settings_document.h"
#include "run/settings_table.h"
#include "run/system_config.h"

namespace dygslam {
namespace {

bool Known(const std::string& key) {
  for (const std::string& k : KnownSettingsKeys()) {
    if (k == key) return true;
    if (k.size() > 2 && k.compare(k.size() - 2, 2, ".*") == 0 &&
        key.compare(0, k.size() - 1, k, 0, k.size() - 1) == 0)
      return true;
  }
  return false;
}

TEST(KnownKeys, EveryKeyTheRunLayerReadsIsKnown) {
  const char* src = std::getenv("DYGSLAM_SOURCE_DIR");
  const std::string path = std::string(src ? src : ".") + "/config/bonn.yaml";
  std::ifstream in(path);
  ASSERT_TRUE(in) << path;
  std::stringstream text;
  text << in.rdbuf();
  KeyLookupRecorder recorder;
  const Settings settings = ParseSettings(text.str(), path);
  SystemOptionsFromSettings(settings);
  OctoMapOptions octomap;
  ReadOptions(ConfigReader::FromString(text.str(), path), &octomap);
  // The readers looked up far more keys than the file has (every optional key of every section).
  ASSERT_GT(recorder.keys().size(), 60u);
  std::vector<std::string> unknown;
  for (const std::string& key : recorder.keys())
    if (!Known(key)) unknown.push_back(key);
  EXPECT_TRUE(unknown.empty()) << "read but not in KnownSettingsKeys(): " << [&] {
    std::string s;
    for (const std::string& k : unknown) s += k + " ";
    return s;
  }();
}

// The settings document (`dygslam settings`, docs/settings.md) lists every known key once, with
// the defaults of the options structs; only the camera intrinsics and distortion are required.
TEST(KnownKeys, SettingsDocumentGivesEveryOptionalKeyItsDefault) {
  const std::vector<SettingDoc> entries = SettingDocs();
  ASSERT_EQ(entries.size(), KnownSettingsKeys().size());
  std::vector<std::string> required;
  std::map<std::string, std::string> defaults;
  for (const SettingDoc& e : entries) {
    EXPECT_FALSE(e.default_value.empty()) << e.key;
    EXPECT_TRUE(defaults.emplace(e.key, e.default_value).second) << "listed twice: " << e.key;
    if (e.required) required.push_back(e.key);
  }
  EXPECT_EQ(required,
            (std::vector<std::string>{"Camera.fx", "Camera.fy", "Camera.cx", "Camera.cy",
                                      "Camera.k1", "Camera.k2", "Camera.p1", "Camera.p2"}));
  EXPECT_EQ(defaults["ORBextractor.nFeatures"], std::to_string(OrbExtractorOptions{}.num_features));
  EXPECT_EQ(defaults["Tracking.init_min_features"],
            std::to_string(TrackingOptions{}.init_min_features));
  EXPECT_EQ(defaults["LocalMapping.cull_keyframes"],
            LocalMappingOptions{}.cull_keyframes ? "true" : "false");
  EXPECT_EQ(defaults["LoopClosing.enabled"], LoopClosingOptions{}.enabled ? "true" : "false");
  EXPECT_EQ(defaults["Detector.every_n_frames"],
            std::to_string(SystemOptions{}.detection_every_n_frames));
  EXPECT_EQ(defaults["OctoMap.resolution"], "0.05");
  EXPECT_EQ(defaults["Tracking.max_frames_between_keyframes"], "Camera.fps");
  // The Markdown form has one row per key.
  const std::string markdown = SettingsMarkdown();
  for (const SettingDoc& e : entries)
    EXPECT_NE(markdown.find("| `" + e.key + "` |"), std::string::npos) << e.key;
}

}  // namespace
}  // namespace dygslam
