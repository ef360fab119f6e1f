// Settings values a hostile or careless user writes: absurd magnitudes, a section given as a list,
// complex and null keys, deep nesting, an implausible Camera.bf, huge and binary values, an unknown
// dynamic class, a pipe without a writer. Each case is config/bonn.yaml with lines appended or
// replaced, read through the functions `dygslam run` / `map` use (ParseSettings,
// SystemOptionsFromSettings, ReadOptions).
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#include "core/base/error.h"
#include "core/base/input_file.h"
#include "core/config/settings.h"
#include "mapping/octomap_settings.h"
#include "run/settings_table.h"
#include "run/system_config.h"
#include "tests/support/settings_text.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

using testing::BonnYaml;
using testing::CountLines;

bool Contains(const std::string& text, const std::string& needle) {
  return text.find(needle) != std::string::npos;
}

// Everything a run reads from the settings; the warnings LoadSettings would print.
std::vector<std::string> ReadAll(const std::string& text) {
  const Settings settings = ParseSettings(text, "bad.yaml");
  SystemOptionsFromSettings(settings);
  OctoMapOptions octomap;
  ReadOptions(settings.reader, &octomap);
  return settings.warnings;
}

// The InputError message of reading `text` ("" and a test failure when it is accepted).
std::string ErrorOf(const std::string& text) {
  try {
    ReadAll(text);
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "accepted:\n" << text.substr(text.size() > 300 ? text.size() - 300 : 0);
  return "";
}

// bonn.yaml with `line` replaced.
std::string Replace(const std::string& line, const std::string& replacement) {
  std::string text = BonnYaml();
  const size_t at = text.find(line);
  EXPECT_NE(at, std::string::npos) << line;
  if (at != std::string::npos) text.replace(at, line.size(), replacement);
  return text;
}

// Values of 1e20 (and NaN) for keys that were only checked for being
// finite were accepted (an OctoMap beam of 1e20 m, a search radius of 1e20 px, ...); each is now
// an error naming the key and its line.
TEST(SettingsValues, AbsurdMagnitudesOfTheRemainingKeysAreErrors) {
  for (const auto& [section, key] : {std::pair<std::string, std::string>{"DynamicFilter", "alpha"},
                                     {"DynamicFilter", "Q"},
                                     {"LoopClosing", "revisit_min_path_m"},
                                     {"LoopClosing", "max_correction_m"}}) {
    for (const char* value : {"1e20", ".nan"}) {
      const std::string text = BonnYaml() + "\n" + section + ":\n  " + key + ": " + value + "\n";
      const std::string message = ErrorOf(text);
      EXPECT_TRUE(Contains(message, "key '" + section + "." + key + "'")) << message;
      EXPECT_TRUE(Contains(message, "bad.yaml:" + std::to_string(CountLines(text)))) << message;
    }
  }
  const std::string octomap = BonnYaml() + "\nOctoMap:\n  max_range: 1e20\n";
  const std::string message = ErrorOf(octomap);
  EXPECT_TRUE(Contains(message, "key 'OctoMap.max_range'")) << message;
  // The shipped values and the paper's pass.
  EXPECT_NO_THROW(ReadAll(BonnYaml() + "\nDynamicFilter:\n  alpha: 0.4\n  Q: 0.09\n"));
}

// `OctoMap: [1, 2]` warned "unknown key 'OctoMap'" before the section error; a known
// section given as a list or a single value is the section's error only.
TEST(SettingsValues, SectionGivenAsListIsAnErrorWithoutAFalseUnknownKeyWarning) {
  // bonn.yaml holds top-level sensor keys only: the cases are appended to it.
  const std::string base = BonnYaml();
  const int line = CountLines(base) + 1;
  for (const std::string section : {"OctoMap", "Detector", "Tracking", "LoopClosing"}) {
    const std::string text = base + section + ": [1, 2]\n";
    Settings settings = ParseSettings(text, "bad.yaml");
    EXPECT_TRUE(settings.warnings.empty()) << section << ": " << settings.warnings.front();
    const std::string message = ErrorOf(text);
    EXPECT_TRUE(Contains(message, "bad.yaml:" + std::to_string(line) + ":")) << message;
    EXPECT_TRUE(Contains(message, "section '" + section + "' must be a map")) << message;
  }
  // Viewer (ORB-SLAM2's, not used): accepted in any shape, without a warning.
  EXPECT_TRUE(ReadAll(BonnYaml() + "Viewer: [1, 2]\n").empty());
  // A real unknown section still warns.
  const std::vector<std::string> warnings = ReadAll(BonnYaml() + "OctoMapp: [1, 2]\n");
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_TRUE(Contains(warnings[0], "unknown key 'OctoMapp' (did you mean 'OctoMap'?)"))
      << warnings[0];
}

// Complex keys and null keys were skipped without a word.
TEST(SettingsValues, ComplexAndNullKeysAreErrorsWithTheirLine) {
  const int line = CountLines(BonnYaml()) + 1;
  const std::pair<std::string, std::string> cases[] = {
      {"? [Camera.fx, Camera.fy]\n: 500\n", "a list used as a key"},
      {"? {a: 1}\n: 500\n", "a map used as a key"},
      {"~: 500\n", "empty or null key"},
      {"null: 500\n", "empty or null key"},
      {"Tracking:\n  ~: 7\n", "empty or null key"},
  };
  for (const auto& [extra, what] : cases) {
    const std::string message = ErrorOf(BonnYaml() + extra);
    const int expected_line = line + (extra.rfind("Tracking", 0) == 0 ? 1 : 0);
    EXPECT_TRUE(Contains(message, "bad.yaml:" + std::to_string(expected_line) + ":"))
        << extra << message;
    EXPECT_TRUE(Contains(message, what)) << extra << message;
  }
}

// Nesting deep enough for yaml-cpp's own guard said "malformed YAML: bad file".
TEST(SettingsValues, DeepNestingSaysSoAtAnyDepth) {
  const int line = CountLines(BonnYaml()) + 2;
  for (const int depth : {40, 5000}) {
    const std::string text = BonnYaml() + "Tracking:\n  deep: " + std::string(depth, '[') +
                             std::string(depth, ']') + "\n";
    const std::string message = ErrorOf(text);
    EXPECT_TRUE(Contains(message, "bad.yaml:" + std::to_string(line) + ": nested deeper than 32"))
        << depth << ": " << message;
    EXPECT_FALSE(Contains(message, "bad file")) << message;
  }
}

// Camera.bf is the baseline times fx; bf / fx <= 0 or > 1 m is no RGB-D camera.
TEST(SettingsValues, ImplausibleCameraBfIsAnErrorNamingKeyAndLine) {
  const std::string base = BonnYaml();
  const int line = CountLines(base.substr(0, base.find("Camera.bf:"))) + 1;
  for (const char* value : {"0.0", "-40.0", "4000.0", "1e300"}) {
    const std::string message =
        ErrorOf(Replace("Camera.bf: 40.0", "Camera.bf: " + std::string(value)));
    EXPECT_TRUE(Contains(message, "bad.yaml:" + std::to_string(line) + ": key 'Camera.bf'"))
        << value << ": " << message;
    EXPECT_TRUE(Contains(message, "baseline")) << message;
  }
  // The presets' 40 (0.075 m at fx 535) and a wide 0.5 m baseline are fine.
  EXPECT_NO_THROW(ReadAll(base));
  EXPECT_NO_THROW(ReadAll(Replace("Camera.bf: 40.0", "Camera.bf: 270.0")));
}

// A 50 MB value was echoed whole into the message; binary bytes went out raw.
TEST(SettingsValues, HugeAndBinaryValuesAreEchoedBoundedAndEscaped) {
  // 4 MB (50 MB behaves the same; yaml-cpp takes ~1 s per MB to parse).
  const std::string huge(4 << 20, 'a');
  const std::string m1 = ErrorOf(BonnYaml() + "Detector:\n  model: " + huge + "\n");
  EXPECT_LT(m1.size(), 2000u) << m1.substr(0, 300);
  EXPECT_TRUE(Contains(m1, "Detector.model")) << m1.substr(0, 300);
  EXPECT_TRUE(Contains(m1, "(4194304 bytes)")) << m1;
  const std::string m2 =
      ErrorOf(BonnYaml() + "Tracking.init_min_features: " + std::string(1 << 20, '7') + "x\n");
  EXPECT_LT(m2.size(), 1000u) << m2.substr(0, 300);
  EXPECT_TRUE(Contains(m2, "Tracking.init_min_features")) << m2;
  EXPECT_TRUE(Contains(m2, "(1048577 bytes)")) << m2;
  // A quoted value with an escape sequence and a NUL: escaped in the message.
  const std::string m3 = ErrorOf(BonnYaml() + "Tracking.init_min_features: \"4\\e[31m\\0\"\n");
  EXPECT_FALSE(Contains(m3, "\x1b")) << m3;
  EXPECT_TRUE(Contains(m3, "4\\x1b[31m\\x00")) << m3;
  // A long unknown key (YAML's simple keys stop at 1024 characters): the warning is bounded too.
  const std::vector<std::string> warnings = ReadAll(BonnYaml() + std::string(1000, 'K') + ": 1\n");
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_LT(warnings[0].size(), 400u) << warnings[0];
  EXPECT_TRUE(Contains(warnings[0], "(1000 bytes)")) << warnings[0];
}

// A misspelt Detector.dynamic_classes entry named the names file but not the settings key.
TEST(SettingsValues, UnknownDynamicClassNamesTheSettingsKeyAndLine) {
  const fs::path dir = testing::MakeTempDir("settings_values");
  std::ofstream(dir / "two.names") << "person\ncar\n";
  const std::string detector = "Detector:\n  cfg: " + (dir / "x.cfg").string() +
                               "\n  weights: " + (dir / "x.weights").string() +
                               "\n  names: " + (dir / "two.names").string() + "\n";
  const int line = CountLines(BonnYaml()) + 5;
  const std::string message =
      ErrorOf(BonnYaml() + detector + "  dynamic_classes: [person, persn]\n");
  EXPECT_TRUE(
      Contains(message, "bad.yaml:" + std::to_string(line) + ": key 'Detector.dynamic_classes'"))
      << message;
  EXPECT_TRUE(Contains(message, "'persn' is not a class")) << message;
  EXPECT_TRUE(Contains(message, "two.names: person, car")) << message;
  // Classes of the model pass; so do aliases (body -> person).
  EXPECT_NO_THROW(ReadAll(BonnYaml() + detector + "  dynamic_classes: [car, person]\n"));
  std::ofstream(dir / "two.names") << "body\ncar\n";
  EXPECT_NO_THROW(ReadAll(BonnYaml() + detector + "  dynamic_classes: [person]\n"));
}

// A settings file or list given as a named pipe nobody writes into blocked
// forever; it is an error after a bounded wait, and a pipe with a writer still works.
TEST(SettingsValues, PipeWithoutWriterIsAnErrorAfterABoundedWait) {
  const fs::path dir = testing::MakeTempDir("settings_values_fifo");
  const std::string fifo = (dir / "settings.yaml").string();
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  const auto t0 = std::chrono::steady_clock::now();
  try {
    ReadPipeBounded(fifo, 1 << 20, "settings file", 0.5);
    ADD_FAILURE() << "read a FIFO without a writer";
  } catch (const InputError& e) {
    EXPECT_TRUE(Contains(e.what(), fifo + ": settings file is a pipe (FIFO) with nothing written"))
        << e.what();
  }
  const double waited =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_GE(waited, 0.4);
  EXPECT_LT(waited, 5.0);
  // With a writer: the whole content, and LoadSettings reads it.
  std::thread writer([&] { std::ofstream(fifo) << BonnYaml(); });
  const Settings settings = LoadSettings(fifo);
  writer.join();
  EXPECT_DOUBLE_EQ(settings.camera.fx, ParseSettings(BonnYaml(), "x").camera.fx);
}

}  // namespace
}  // namespace dygslam
