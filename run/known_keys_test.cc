// Every key the run layer reads is a known settings key: a key that works must not be warned
// about as "unknown" (KnownSettingsKeys() is a list of its own; it had drifted from the readers:
// Tracking.fallback_* and the local-mapping schedule keys were read but warned about).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "core/config/config_reader.h"
#include "core/config/settings.h"
#include "run/mapping_config.h"
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
  ASSERT_GT(recorder.keys().size(), 100u);
  std::vector<std::string> unknown;
  for (const std::string& key : recorder.keys())
    if (!Known(key)) unknown.push_back(key);
  EXPECT_TRUE(unknown.empty()) << "read but not in KnownSettingsKeys(): " << [&] {
    std::string s;
    for (const std::string& k : unknown) s += k + " ";
    return s;
  }();
}

}  // namespace
}  // namespace dygslam
