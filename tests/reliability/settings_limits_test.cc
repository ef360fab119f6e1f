// Settings text read through the functions `dygslam run` / `map` use (ParseSettings,
// SystemOptionsFromSettings, ReadOptions), at the limits of what a key or value can be:
//   - a 100,000-character YAML key: plain (YAML's simple keys end at 1024 characters: a parse
//     error), quoted, in a section, or an explicit `? key` (no length limit: an unknown-key
//     warning). The message names the file and line, and never echoes the key whole.
//   - every settings key given 1e20 is an error naming it (a value like
//     `DynamicFilter.fundamental_threshold: 99999999999999999999` would make every point
//     consistent with the camera's motion), and Detector.weights / names without Detector.cfg
//     are refused.
#include <gtest/gtest.h>

#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/config/settings.h"
#include "mapping/octomap_settings.h"
#include "run/settings_table.h"
#include "run/system_config.h"
#include "tests/support/settings_text.h"

namespace dygslam {
namespace {

using testing::BonnYaml;
using testing::CountLines;

bool Contains(const std::string& text, const std::string& needle) {
  return text.find(needle) != std::string::npos;
}

// Reads `text` as a run does: the warnings, or the InputError's message in *error.
std::vector<std::string> ReadAll(const std::string& text, std::string* error) {
  try {
    const Settings settings = ParseSettings(text, "long.yaml");
    SystemOptionsFromSettings(settings);
    OctoMapOptions octomap;
    ReadOptions(settings.reader, &octomap);
    return settings.warnings;
  } catch (const InputError& e) {
    *error = e.what();
  }
  return {};
}

// Every message (error or warning) about `text` is shorter than `limit` characters, says where,
// and there is at least one.
void ExpectBoundedMessages(const std::string& text, size_t limit, const std::string& where) {
  std::string error;
  std::vector<std::string> messages = ReadAll(text, &error);
  if (!error.empty()) messages.push_back(error);
  ASSERT_FALSE(messages.empty()) << "a 100,000-character key was accepted without a word";
  for (const std::string& m : messages) {
    EXPECT_LT(m.size(), limit) << m.substr(0, 400);
    EXPECT_TRUE(Contains(m, where)) << m.substr(0, 400);
    EXPECT_FALSE(Contains(m, std::string(2000, 'k'))) << m.substr(0, 400);
  }
}

TEST(SettingsLimits, HundredThousandCharacterKeyGivesABoundedMessage) {
  const std::string key(100000, 'k');
  const std::string line = std::to_string(CountLines(BonnYaml()) + 1);
  // Plain key at the top level and in a section; quoted key.
  ExpectBoundedMessages(BonnYaml() + key + ": 1\n", 2000, "long.yaml:" + line);
  ExpectBoundedMessages(BonnYaml() + "Tracking:\n  " + key + ": 1\n", 2000, "long.yaml:");
  ExpectBoundedMessages(BonnYaml() + "\"" + key + "\": 1\n", 2000, "long.yaml:" + line);
  // An explicit key (`? key` / `: value`) has no length limit in YAML: an unknown-key warning,
  // bounded, with the key's size.
  std::string error;
  const std::vector<std::string> warnings = ReadAll(BonnYaml() + "? " + key + "\n: 1\n", &error);
  EXPECT_EQ(error, "");
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_LT(warnings[0].size(), 600u) << warnings[0].substr(0, 400);
  EXPECT_TRUE(Contains(warnings[0], "long.yaml:" + line)) << warnings[0].substr(0, 400);
  EXPECT_TRUE(Contains(warnings[0], "(100000 bytes)")) << warnings[0].substr(0, 400);
}

// bonn.yaml with `key` set to `value`: a flat key's line replaced; a section key replaced in its
// section, or added at its top, or appended as a new section (as tests/reliability/probe/set_key.py
// does).
std::string WithKey(const std::string& key, const std::string& value) {
  std::vector<std::string> lines;
  std::istringstream in(BonnYaml());
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  const auto starts = [](const std::string& line, const std::string& prefix) {
    return std::regex_search(line, std::regex("^" + prefix + "\\s*:"));
  };
  bool done = false;
  for (std::string& line : lines) {
    if (!done && starts(line, std::regex_replace(key, std::regex("\\."), "\\."))) {
      line = key + ": " + value;
      done = true;
    }
  }
  const size_t dot = key.find('.');
  if (!done && dot != std::string::npos) {
    const std::string section = key.substr(0, dot), sub = key.substr(dot + 1);
    for (size_t i = 0; i < lines.size() && !done; ++i) {
      if (!std::regex_match(lines[i], std::regex(section + "\\s*:\\s*(#.*)?"))) continue;
      for (size_t j = i + 1; j < lines.size() && (lines[j].empty() || lines[j][0] == ' '); ++j) {
        if (starts(lines[j], "\\s+" + sub)) {
          lines[j] = "  " + sub + ": " + value;
          done = true;
          break;
        }
      }
      if (!done) lines.insert(lines.begin() + i + 1, "  " + sub + ": " + value);
      done = true;
    }
    if (!done) lines.insert(lines.end(), {section + ":", "  " + sub + ": " + value});
  }
  std::string text;
  for (const std::string& line : lines) text += line + "\n";
  return text;
}

TEST(SettingsLimits, EverySettingsKeyRefusesAnAbsurdlyLargeValue) {
  std::vector<std::string> accepted;
  int checked = 0;
  for (const std::string& key : KnownSettingsKeys()) {
    // Accepted and not used (ORB-SLAM2 / ORB-SLAM3 keys).
    if (key == "Camera.RGB" || key == "Camera.type" || key == "File.version" || key == "Viewer.*")
      continue;
    ++checked;
    std::string error;
    ReadAll(WithKey(key, "99999999999999999999"), &error);
    if (error.empty()) {
      accepted.push_back(key);
      continue;
    }
    // Named by its key (Detector.cfg alone: by the key it needs with it).
    EXPECT_TRUE(Contains(error, key.substr(key.find('.') + 1)) ||
                (key == "Detector.cfg" && Contains(error, "missing required key")))
        << key << ": " << error;
    EXPECT_TRUE(Contains(error, "long.yaml:")) << key << ": " << error;
  }
  EXPECT_GE(checked, 65);
  std::string list;
  for (const std::string& key : accepted) list += " " + key;
  EXPECT_TRUE(accepted.empty()) << "accepted 1e20 for" << list;
  // A value far out of range is refused, and values within the bounds still pass.
  std::string error;
  ReadAll(WithKey("DynamicFilter.fundamental_threshold", "99999999999999999999"), &error);
  EXPECT_TRUE(Contains(error,
                       "key 'DynamicFilter.fundamental_threshold': value 1e+20 is out of range: "
                       "expected > 0 and <= 1000 px"))
      << error;
  error.clear();
  ReadAll(WithKey("LoopClosing.revisit_min_path_m", "12.5") +
              "DynamicFilter:\n  C1: 5\n  delta: 120\n  fundamental_threshold: 2.5\n",
          &error);
  EXPECT_EQ(error, "");
  // Model files without Detector.cfg were ignored without a word.
  error.clear();
  ReadAll(BonnYaml() + "Detector:\n  weights: my.weights\n", &error);
  EXPECT_TRUE(Contains(error, "key 'Detector.weights': given without Detector.cfg")) << error;
}

}  // namespace
}  // namespace dygslam
