// Messages about settings values, read the way `dygslam run` / `map` read them: a range error names
// the file's key and what it expects in the file's keys (never the C++ check), a known key of the
// wrong type gets no unknown-key warning first, and compared numbers print with as many digits as
// it takes to tell them apart.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <octomap/OcTree.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "core/base/echo.h"
#include "core/base/error.h"
#include "core/base/input_file.h"
#include "core/base/stop_signal.h"
#include "core/config/config_reader.h"
#include "core/config/settings.h"
#include "core/io/dataset.h"
#include "core/io/detections_io.h"
#include "mapping/octomap_builder.h"
#include "run/mapping_config.h"
#include "run/system_config.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

std::string BonnYaml() {
  std::ifstream in(std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/bonn.yaml");
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

bool Contains(const std::string& text, const std::string& needle) {
  return text.find(needle) != std::string::npos;
}

// The InputError of reading `text` the way `dygslam run` does ("" and a failure if accepted).
std::string SettingsError(const std::string& text, std::vector<std::string>* warnings = nullptr) {
  try {
    const Settings settings = ParseSettings(text, "bad.yaml");
    if (warnings != nullptr) *warnings = settings.warnings;
    SystemOptionsFromSettings(settings);
    OctoMapOptions octomap;
    ReadOptions(settings.reader, &octomap);
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "accepted:\n" << text.substr(text.size() > 200 ? text.size() - 200 : 0);
  return "";
}

// bonn.yaml with `line` replaced (flat ORB-SLAM2 keys) or a section appended.
std::string WithFlat(const std::string& key, const std::string& value) {
  std::string text = BonnYaml();
  const size_t at = text.find("\n" + key + ":");
  EXPECT_NE(at, std::string::npos) << key;
  const size_t end = text.find('\n', at + 1);
  text.replace(at + 1, end - at - 1, key + ": " + value);
  return text;
}

// Every range error reachable from the settings names the file's key and says what is
// expected in the file's keys, never the C++ condition.
TEST(SettingsMessages, RangeMessagesUseTheFilesKeysNotTheCxxCheck) {
  struct Case {
    std::string text, key, expect;
  };
  const std::vector<Case> cases = {
      {WithFlat("ORBextractor.nFeatures", "0"), "ORBextractor.nFeatures",
       "invalid value 0 (expected nFeatures > 0 and nFeatures <= 100000)"},
      {WithFlat("ORBextractor.nLevels", "0"), "ORBextractor.nLevels", "nLevels >= 1"},
      {WithFlat("ORBextractor.scaleFactor", "1"), "ORBextractor.scaleFactor", "scaleFactor > 1"},
      {WithFlat("ORBextractor.minThFAST", "30"), "ORBextractor.minThFAST",
       "minThFAST <= iniThFAST"},
      {WithFlat("DepthMapFactor", "0"), "DepthMapFactor",
       "DepthMapFactor > 0 and DepthMapFactor finite"},
      {WithFlat("ThDepth", "0"), "ThDepth", "ThDepth > 0"},
      {WithFlat("Camera.fps", "0"), "Camera.fps", "fps > 0"},
      {BonnYaml() + "DynamicFilter:\n  P_init: 2\n", "DynamicFilter.P_init", "P_init <= 1"},
      {BonnYaml() + "DynamicFilter:\n  box_margin_fraction: 2\n",
       "DynamicFilter.box_margin_fraction", "box_margin_fraction <= 1"},
      {BonnYaml() + "DynamicFilter:\n  delta: 0\n", "DynamicFilter.delta", "delta > 0"},
      {BonnYaml() + "Detector:\n  dynamic_classes: []\n", "Detector.dynamic_classes",
       "dynamic_classes not empty"},
  };
  for (const Case& c : cases) {
    const std::string message = SettingsError(c.text);
    EXPECT_TRUE(Contains(message, "bad.yaml:")) << message;
    EXPECT_TRUE(Contains(message, "key '" + c.key + "'")) << message;
    EXPECT_TRUE(Contains(message, c.expect)) << c.expect << "\n" << message;
    for (const char* cxx : {"requires", "&&", "||", "std::", "num_features", "report_all_classes",
                            ".empty()", "min_th_fast", "depth_map_factor"})
      EXPECT_FALSE(Contains(message, cxx)) << cxx << " in: " << message;
  }
}

TEST(SettingsMessages, UserConditionRewritesFieldsToKeys) {
  const std::vector<std::string> keys = KnownSettingsKeys();
  EXPECT_EQ(
      UserCondition("num_features > 0 && num_features <= 100000", "ORBextractor.nFeatures", keys),
      "nFeatures > 0 and nFeatures <= 100000");
  EXPECT_EQ(UserCondition("report_all_classes || !dynamic_classes.empty()",
                          "Detector.dynamic_classes", keys),
            "dynamic_classes not empty");
  EXPECT_EQ(UserCondition("clamping_min > 0 && clamping_min < occupancy_threshold",
                          "OctoMap.clamping_min", keys),
            "clamping_min > 0 and clamping_min < occupancy_threshold");
  EXPECT_EQ(UserCondition("min_th_fast > 0 && min_th_fast <= ini_th_fast", "ORBextractor.minThFAST",
                          keys),
            "minThFAST > 0 and minThFAST <= iniThFAST");
  EXPECT_EQ(UserCondition("delta > 0 && std::isfinite(delta)", "DynamicFilter.delta", keys),
            "delta > 0 and delta finite");
}

// `Detector.dynamic_classes: {a: 1}` warned "unknown key 'Detector.dynamic_classes.a'"
// before the type error; the type error alone is reported.
TEST(SettingsMessages, MistypedKnownKeyGetsNoUnknownKeyWarning) {
  std::vector<std::string> warnings;
  const std::string message =
      SettingsError(BonnYaml() + "Detector:\n  dynamic_classes: {a: 1}\n", &warnings);
  EXPECT_TRUE(Contains(message, "key 'Detector.dynamic_classes'")) << message;
  EXPECT_TRUE(warnings.empty()) << warnings.front();
  // A misspelt key is still warned about.
  const Settings misspelt =
      ParseSettings(BonnYaml() + "Detector:\n  dynamic_clases: [person]\n", "bad.yaml");
  ASSERT_EQ(misspelt.warnings.size(), 1u);
  EXPECT_TRUE(Contains(misspelt.warnings[0], "did you mean 'Detector.dynamic_classes'"))
      << misspelt.warnings[0];
}

// Numbers that differ print differently; the usual ones print as before.
TEST(SettingsMessages, ComparedNumbersPrintWithTheDigitsThatTellThemApart) {
  const double half = 0.5, forged = std::nextafter(0.5, 1.0);
  EXPECT_NE(ExactNumber(half), ExactNumber(forged));
  EXPECT_EQ(std::strtod(ExactNumber(forged).c_str(), nullptr), forged);
  EXPECT_EQ(ExactNumber(half), "0.5");
  EXPECT_EQ(ExactNumber(542.822841), "542.822841");
  EXPECT_EQ(ExactNumber(0.1), "0.1");
}

}  // namespace
}  // namespace dygslam
