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
#include "core/config/setting_table.h"
#include "core/config/settings.h"
#include "core/io/dataset.h"
#include "core/io/detections_io.h"
#include "mapping/octomap_builder.h"
#include "mapping/octomap_settings.h"
#include "run/settings_table.h"
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

// Every range error reachable from the settings names the file's key and says what the key's
// row of the settings table accepts, never the C++ condition of an options Check().
TEST(SettingsMessages, RangeMessagesUseTheFilesKeysNotTheCxxCheck) {
  struct Case {
    std::string text, key, expect;
  };
  const std::vector<Case> cases = {
      {WithFlat("ORBextractor.nFeatures", "0"), "ORBextractor.nFeatures",
       "value 0 is out of range: expected 1 to 100000 (features per image)"},
      {WithFlat("ORBextractor.nLevels", "0"), "ORBextractor.nLevels", "expected 1 to 32"},
      {WithFlat("ORBextractor.scaleFactor", "1"), "ORBextractor.scaleFactor",
       "expected > 1 and < 4"},
      {WithFlat("ORBextractor.minThFAST", "30"), "ORBextractor.minThFAST",
       "value 30 is out of range: expected at most ORBextractor.iniThFAST"},
      {WithFlat("DepthMapFactor", "0"), "DepthMapFactor", "expected 1 to 100000"},
      {WithFlat("ThDepth", "0"), "ThDepth", "expected > 0 and <= 1000"},
      {WithFlat("Camera.fps", "0"), "Camera.fps", "expected > 0 and <= 1000 Hz"},
      {BonnYaml() + "DynamicFilter:\n  P_init: 2\n", "DynamicFilter.P_init", "expected 0 to 1"},
      {BonnYaml() + "DynamicFilter:\n  box_margin_fraction: 2\n",
       "DynamicFilter.box_margin_fraction", "expected 0 to 1"},
      {BonnYaml() + "DynamicFilter:\n  delta: 0\n", "DynamicFilter.delta",
       "expected > 0 and <= 16384 px"},
      {BonnYaml() + "Detector:\n  dynamic_classes: []\n", "Detector.dynamic_classes",
       "expected at least one class name"},
      {BonnYaml() + "Detector:\n  input_width: 100\n", "Detector.input_width",
       "expected 32 to 4096 px, a multiple of 32"},
      {BonnYaml() + "OctoMap:\n  clamping_min: 0.6\n", "OctoMap.clamping_min",
       "expected below OctoMap.occupancy_threshold"},
  };
  for (const Case& c : cases) {
    const std::string message = SettingsError(c.text);
    EXPECT_TRUE(Contains(message, "bad.yaml:")) << message;
    EXPECT_TRUE(Contains(message, "key '" + c.key + "'")) << message;
    EXPECT_TRUE(Contains(message, c.expect)) << c.expect << "\n" << message;
    for (const char* cxx : {"requires", "&&", "||", "std::", "num_features", "report_all_classes",
                            ".empty()", "min_th_fast", "depth_map_factor", "invalid option"})
      EXPECT_FALSE(Contains(message, cxx)) << cxx << " in: " << message;
  }
}

// The settings file `text` with `key: value` (replacing the key's line when bonn.yaml has it).
std::string WithKey(const std::string& key, const std::string& value) {
  if (Contains(BonnYaml(), "\n" + key + ":")) return WithFlat(key, value);
  return BonnYaml() + "\n" + key + ": " + value + "\n";
}

struct RangeRow {
  std::string key;
  SettingRange range;
};

// The numeric rows of every settings table.
std::vector<RangeRow> NumericRows() {
  std::vector<RangeRow> rows;
  for (const auto& r : CameraSettingsTable().rows)
    if (r.numeric()) rows.push_back({r.key(), r.range()});
  for (const auto& r : SystemSettingsTable().rows)
    if (r.numeric()) rows.push_back({r.key(), r.range()});
  for (const auto& r : OctoMapSettingsTable().rows)
    if (r.numeric()) rows.push_back({r.key(), r.range()});
  return rows;
}

std::string Number(double v) { return FormatSettingValue(v); }

// Just outside each finite end of a row's range: an error naming the key and its range.
TEST(SettingsMessages, EveryRowRefusesAValueOutsideItsRange) {
  int checked = 0;
  for (const RangeRow& row : NumericRows()) {
    std::vector<double> outside;
    if (std::isfinite(row.range.min))
      outside.push_back(row.range.min_open ? row.range.min : row.range.min - 1);
    if (std::isfinite(row.range.max))
      outside.push_back(row.range.max_open ? row.range.max : row.range.max + 1);
    if (row.range.multiple_of > 0) outside.push_back(row.range.min + 1);
    for (double value : outside) {
      if (row.range.zero_too && value == 0) continue;
      ASSERT_FALSE(row.range.Contains(value)) << row.key << " " << value;
      const std::string message = SettingsError(WithKey(row.key, Number(value)));
      EXPECT_TRUE(Contains(message, "key '" + row.key + "'")) << row.key << ": " << message;
      EXPECT_TRUE(Contains(message, "out of range: expected " + row.range.Text("").substr(0, 3)))
          << row.key << ": " << message;
      ++checked;
    }
  }
  // Every numeric key of the tables has at least one finite end.
  EXPECT_GE(checked, 50);
}

// The ends of each row's range (or a value just inside an open end) never reach an options
// Check(): the table's ranges lie within what the algorithms accept. A value may still be refused
// by a plausibility check or a relation between keys, by the key's name.
TEST(SettingsMessages, EveryValueARowAcceptsPassesTheOptionsCheck) {
  int accepted = 0;
  for (const RangeRow& row : NumericRows()) {
    const SettingRange& r = row.range;
    std::vector<double> inside;
    const auto inner = [&](double end, double step) {
      if (!std::isfinite(end)) return 1e6 * (step > 0 ? -1 : 1);
      double v = end + step;
      if (!r.Contains(v) && std::isfinite(r.min) && std::isfinite(r.max)) v = (r.min + r.max) / 2;
      return v;
    };
    inside.push_back(r.min_open || !std::isfinite(r.min) ? inner(r.min, 1) : r.min);
    inside.push_back(r.max_open || !std::isfinite(r.max) ? inner(r.max, -1) : r.max);
    for (double value : inside) {
      if (!r.Contains(value)) continue;  // an open end next to another (no integer inside)
      std::string message;
      try {
        const Settings settings = ParseSettings(WithKey(row.key, Number(value)), "in.yaml");
        SystemOptionsFromSettings(settings);
        OctoMapOptions octomap;
        ReadOptions(settings.reader, &octomap);
        ++accepted;
        continue;
      } catch (const InputError& e) {
        message = e.what();
      }
      EXPECT_FALSE(Contains(message, "invalid option"))
          << row.key << " = " << value << ": " << message;
      EXPECT_TRUE(Contains(message, "in.yaml:")) << message;
    }
  }
  EXPECT_GE(accepted, 50);
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
