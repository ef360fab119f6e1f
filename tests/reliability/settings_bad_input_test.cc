// Settings files that a hostile or careless user writes (items 1, 4, 5, 6): a recursive
// YAML alias, misspelt keys, a section given as a list, an unknown detector model, absurd camera
// values, and errors that must use the file's key names. Each case is config/bonn.yaml with a few
// lines appended or replaced, read through the same functions as `dygslam run` / `map`
// (ParseSettings, SystemOptionsFromSettings, ReadOptions for the OctoMap section).
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "core/config/settings.h"
#include "mapping/octomap_settings.h"
#include "run/settings_table.h"
#include "run/system_config.h"
#include "tests/support/settings_text.h"

namespace dygslam {
namespace {

using testing::BonnYaml;
using testing::CountLines;

// bonn.yaml with `line` replaced by `replacement` (the line must exist).
std::string Replace(const std::string& line, const std::string& replacement) {
  std::string text = BonnYaml();
  const size_t at = text.find(line);
  EXPECT_NE(at, std::string::npos) << line;
  if (at != std::string::npos) text.replace(at, line.size(), replacement);
  return text;
}

// Everything a run reads from the settings.
void ReadAll(const std::string& text, UnknownKeyPolicy policy = UnknownKeyPolicy::kWarn,
             std::vector<std::string>* warnings = nullptr) {
  const Settings settings = ParseSettings(text, "bad.yaml", {policy, false});
  SystemOptionsFromSettings(settings);
  OctoMapOptions octomap;
  ReadOptions(settings.reader, &octomap);
  if (warnings) *warnings = settings.warnings;
}

// The InputError message of reading `text` ("" and a test failure when it is accepted).
std::string ErrorOf(const std::string& text, UnknownKeyPolicy policy = UnknownKeyPolicy::kWarn) {
  try {
    ReadAll(text, policy);
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "accepted:\n" << text.substr(text.size() > 300 ? text.size() - 300 : 0);
  return "";
}

bool Contains(const std::string& text, const std::string& needle) {
  return text.find(needle) != std::string::npos;
}

// A self-referencing alias must not crash `run` and `map` (stack overflow walking the keys).
TEST(SettingsBadInput, RecursiveAliasIsAnErrorWithTheLine) {
  const std::string base = BonnYaml();
  const int line = CountLines(base) + 1;
  const std::string message = ErrorOf(base + "Tracking: &t {init_min_features: 300, self: *t}\n");
  EXPECT_TRUE(Contains(message, "bad.yaml:" + std::to_string(line) + ":")) << message;
  EXPECT_TRUE(Contains(message, "recursive alias")) << message;
  // Through a list, and two levels down.
  EXPECT_TRUE(Contains(ErrorOf(base + "Tracking: &t {items: [1, *t]}\n"), "recursive alias"));
  EXPECT_TRUE(Contains(ErrorOf(base + "Detector: &d {a: {b: {c: *d}}}\n"), "recursive alias"));
}

TEST(SettingsBadInput, DeepNestingAndAliasBombsAreBounded) {
  const std::string base = BonnYaml();
  std::string deep = "Deep: ";
  for (int i = 0; i < 200; ++i) deep += "{a: ";
  deep += "1";
  for (int i = 0; i < 200; ++i) deep += "}";
  EXPECT_TRUE(Contains(ErrorOf(base + deep + "\n"), "nested deeper than")) << deep.size();
  // 2^40 values once aliases are expanded: refused after a bounded walk, not walked.
  std::string bomb = "b0: &b0 [x, x]\n";
  for (int i = 1; i <= 40; ++i) {
    bomb += "b" + std::to_string(i) + ": &b" + std::to_string(i) + " [*b" + std::to_string(i - 1) +
            ", *b" + std::to_string(i - 1) + "]\n";
  }
  EXPECT_TRUE(Contains(ErrorOf(base + bomb), "aliases expanded"));
}

// An unknown model fell back to the default and dropped input_width, thresholds, classes.
TEST(SettingsBadInput, UnknownDetectorModelIsAnErrorNamingKeyAndLine) {
  const std::string base = BonnYaml();
  const int line = CountLines(base) + 2;
  const std::string message = ErrorOf(
      base +
      "Detector:\n  model: yolo-nonexistent-9\n  input_width: 416\n  confidence_threshold: 0.4\n");
  EXPECT_TRUE(Contains(message, "bad.yaml:" + std::to_string(line) + ":")) << message;
  EXPECT_TRUE(Contains(message, "Detector.model")) << message;
  EXPECT_TRUE(Contains(message, "yolo-nonexistent-9")) << message;
}

TEST(SettingsBadInput, MisspeltKeysWarnWithLineAndClosestKey) {
  const std::string base = BonnYaml();
  const int first = CountLines(base) + 1;
  const std::string text = base +
                           "Camera.fxx: 500\n"
                           "ORBextractor.nFeature: 2000\n"
                           "DynamicFilter.treshold: 0.6\n"
                           "DynamicFiltr:\n"
                           "  C1: 2.0\n"
                           "Completely.unrelated_thing: 1\n";
  std::vector<std::string> warnings;
  ASSERT_NO_THROW(ReadAll(text, UnknownKeyPolicy::kWarn, &warnings));
  ASSERT_EQ(warnings.size(), 5u);
  const std::string expected[][2] = {{"Camera.fxx", "Camera.fx"},
                                     {"ORBextractor.nFeature", "ORBextractor.nFeatures"},
                                     {"DynamicFilter.treshold", "DynamicFilter.threshold"},
                                     {"DynamicFiltr.C1", "DynamicFilter.C1"}};
  const int lines[] = {first, first + 1, first + 2, first + 4};
  for (int i = 0; i < 4; ++i) {
    EXPECT_TRUE(Contains(warnings[i], "bad.yaml:" + std::to_string(lines[i]) + ":")) << warnings[i];
    EXPECT_TRUE(Contains(warnings[i], "unknown key '" + expected[i][0] + "'")) << warnings[i];
    EXPECT_TRUE(Contains(warnings[i], "did you mean '" + expected[i][1] + "'")) << warnings[i];
  }
  EXPECT_FALSE(Contains(warnings[4], "did you mean")) << warnings[4];
  // The option that makes them errors.
  const std::string message = ErrorOf(text, UnknownKeyPolicy::kError);
  EXPECT_TRUE(Contains(message, "bad.yaml:" + std::to_string(first) + ":")) << message;
  EXPECT_TRUE(Contains(message, "Camera.fxx")) << message;
  // The shipped presets have no unknown key.
  for (const char* preset : {"bonn", "tum1", "tum2", "tum3"}) {
    std::ifstream in(std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/" + preset + ".yaml");
    std::stringstream s;
    s << in.rdbuf();
    EXPECT_NO_THROW(ReadAll(s.str(), UnknownKeyPolicy::kError)) << preset;
  }
}

TEST(SettingsBadInput, SectionGivenAsAListIsAnError) {
  const std::string base = BonnYaml();
  const int line = CountLines(base) + 1;
  const std::string message = ErrorOf(base + "DynamicFilter: [threshold, 0.5]\n");
  EXPECT_TRUE(Contains(message, "bad.yaml:" + std::to_string(line) + ":")) << message;
  EXPECT_TRUE(Contains(message, "section 'DynamicFilter' must be a map")) << message;
  EXPECT_TRUE(Contains(ErrorOf(base + "Tracking:\n  - init_min_features\n  - 300\n"),
                       "section 'Tracking' must be a map"));
}

// Accepted before, giving a ~1e-9 m trajectory with every frame "ok".
TEST(SettingsBadInput, ImplausibleCameraValuesAreErrors) {
  struct Case {
    std::string line, replacement, key;
  };
  const Case cases[] = {
      {"Camera.fx: 542.822841", "Camera.fx: 1e308", "Camera.fx"},
      {"Camera.fy: 542.576870", "Camera.fy: 0.5", "Camera.fy"},
      {"Camera.cx: 315.593520", "Camera.cx: -1000", "Camera.cx"},
      {"Camera.cy: 237.756098", "Camera.cy: 5000", "Camera.cy"},
      {"Camera.k1: 0.039903", "Camera.k1: 1e10", "Camera.k1"},
      {"Camera.p2: -0.000144", "Camera.p2: 3", "Camera.p2"},
  };
  const std::string base = BonnYaml();
  for (const Case& c : cases) {
    const int line = CountLines(base.substr(0, base.find(c.line))) + 1;
    const std::string message = ErrorOf(Replace(c.line, c.replacement));
    EXPECT_TRUE(Contains(message, "bad.yaml:" + std::to_string(line) + ":")) << message;
    EXPECT_TRUE(Contains(message, "key '" + c.key + "'")) << message;
  }
  // The shipped values pass (tum1 has k3 = 1.16, the largest of the presets).
  EXPECT_NO_THROW(ReadAll(BonnYaml()));
}

// Check() failures used the options struct's names (c1, p_init) without file or line.
TEST(SettingsBadInput, ModuleErrorsUseTheFileKeysAndLines) {
  const std::string base = BonnYaml();
  const int line = CountLines(base) + 2;
  struct Case {
    std::string section, key, value;
  };
  const Case cases[] = {{"DynamicFilter", "C1", "-1"},
                        {"DynamicFilter", "P_init", "2"},
                        {"DynamicFilter", "Q", "-0.5"},
                        {"Detector", "input_width", "33"},
                        {"Detector", "nms_threshold", "7"}};
  for (const Case& c : cases) {
    const std::string message = ErrorOf(base + c.section + ":\n  " + c.key + ": " + c.value + "\n");
    EXPECT_TRUE(Contains(message, "bad.yaml:" + std::to_string(line) + ":")) << message;
    EXPECT_TRUE(Contains(message, "key '" + c.section + "." + c.key + "'")) << message;
  }
  const std::string c1 = ErrorOf(base + "DynamicFilter:\n  C1: -1\n");
  EXPECT_FALSE(Contains(c1, "c1")) << c1;
}

}  // namespace
}  // namespace dygslam
