// The final re-probe of issue 20 (2026-12-02, session 8), library half: settings text read through
// the functions `dygslam run` / `map` use (ParseSettings, SystemOptionsFromSettings, ReadOptions).
//   L1  a 100,000-character YAML key: plain (YAML's simple keys end at 1024 characters: a parse
//       error), quoted, in a section, or an explicit `? key` (no length limit: an unknown-key
//       warning). The message names the file and line, and never echoes the key whole.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/config/settings.h"
#include "run/mapping_config.h"
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

TEST(FinalReprobe, HundredThousandCharacterKeyGivesABoundedMessage) {
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

}  // namespace
}  // namespace dygslam
