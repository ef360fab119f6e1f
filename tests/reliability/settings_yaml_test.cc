// YAML features a settings file must not use silently: a second document ("---" or "..." then
// more keys), a merge key ("<<: *base"), a stray comma; a value that underflows a double is named
// as such; absurd Camera.fps / ThDepth / DepthMapFactor name their own key and line.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/config/config_reader.h"
#include "core/config/settings.h"
#include "core/io/dataset.h"
#include "run/settings_table.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

// The InputError message of reading `text` ("" and a failure when it is accepted).
std::string ReadError(const std::string& text) {
  try {
    const ConfigReader reader = ConfigReader::FromString(text, "bad.yaml");
    reader.Get<double>("Camera.fx", 0);
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "accepted:\n" << text;
  return "";
}

// The keys of a second document are not dropped without a word.
TEST(SettingsYaml, SecondDocumentIsAnError) {
  for (const std::string& text : {std::string("Camera.fx: 500\n---\nCamera.fy: 500\n"),
                                  std::string("Camera.fx: 500\n...\nCamera.fy: 12\n")}) {
    const std::string e = ReadError(text);
    EXPECT_NE(e.find("bad.yaml:3:"), std::string::npos) << e;
    EXPECT_NE(e.find("second YAML document"), std::string::npos) << e;
  }
  // A document marker at the start, or a trailing one with nothing after it, is fine.
  for (const std::string& text :
       {std::string("---\nCamera.fx: 500\n"), std::string("Camera.fx: 500\n---\n"),
        std::string("Camera.fx: 500\n...\n"), std::string("%YAML:1.0\n---\nCamera.fx: 7\n")}) {
    EXPECT_NO_THROW({
      const ConfigReader reader = ConfigReader::FromString(text, "ok.yaml");
      EXPECT_GT(reader.Get<double>("Camera.fx", 0), 0) << text;
    }) << text;
  }
}

// Found by the settings fuzzer (CI): a ',' at the top level made yaml-cpp's LoadAll hand out empty
// documents at the same place forever (the run hung). Now an error naming the file and line.
TEST(SettingsYaml, StrayCommaIsAnErrorNotAHang) {
  for (const std::string& text :
       {std::string(","), std::string(", Camera.fx: 500\n"),
        std::string("Camera.fx: 500\n---\n,\n"), std::string("%YAML:1.0\n---\n, x\n")}) {
    const std::string e = ReadError(text);
    EXPECT_NE(e.find("bad.yaml:"), std::string::npos) << e;
    EXPECT_TRUE(e.find("','") != std::string::npos || e.find("malformed YAML") != std::string::npos)
        << e;
  }
  // Commas inside flow collections and inside values are of course fine.
  const ConfigReader reader =
      ConfigReader::FromString("Camera.fx: 500\nlist: [1, 2, 3]\nname: a, b\n", "ok.yaml");
  EXPECT_EQ(reader.Get<std::vector<int>>("list", {}), (std::vector<int>{1, 2, 3}));
  EXPECT_EQ(reader.Get<std::string>("name", ""), "a, b");
}

// A merge key is an error with its line, not a value dropped below a key named "<<".
TEST(SettingsYaml, MergeKeyIsAnError) {
  for (const std::string& text :
       {std::string("base: &b {alpha: 0.9}\nDynamicFilter:\n  <<: *b\n"),
        std::string("x: 1\ny: 2\nDynamicFilter: {<<: {threshold: 0.7}}\n")}) {
    const std::string e = ReadError(text);
    EXPECT_NE(e.find("bad.yaml:3:"), std::string::npos) << e;
    EXPECT_NE(e.find("merge key '<<' is not supported"), std::string::npos) << e;
  }
  // A quoted "<<" is a plain (unknown) key name, no merge.
  EXPECT_NO_THROW(ConfigReader::FromString("\"<<\": 1\n", "ok.yaml"));
}

// An underflowing value is named as such.
TEST(SettingsYaml, UnderflowIsNamed) {
  const std::string e = ReadError("Camera.fx: 4.9e-324\n");
  EXPECT_NE(e.find("underflow"), std::string::npos) << e;
  EXPECT_EQ(e.find("finite"), std::string::npos) << e;
  EXPECT_NE(ReadError("Camera.fx: 1e400\n").find("finite"), std::string::npos);
}

// Absurd frame rate, close-depth factor and depth scale (either way) are errors naming their own
// key and line.
TEST(SettingsYaml, AbsurdFpsAndThDepthNameTheirKey) {
  std::ifstream in(std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/bonn.yaml");
  const std::string bonn((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (const auto& [key, line_text] :
       {std::pair<std::string, std::string>{"Camera.fps", "Camera.fps: 1e20"},
        {"ThDepth", "ThDepth: 1e20"},
        {"DepthMapFactor", "DepthMapFactor: 1e20"},
        {"DepthMapFactor", "DepthMapFactor: 1e-9"},
        {"DepthMapFactor", "DepthMapFactor: 0.5"}}) {
    std::string text = bonn;
    const size_t at = text.find("\n" + key + ":");
    ASSERT_NE(at, std::string::npos) << key;
    text.replace(at + 1, text.find('\n', at + 1) - at - 1, line_text);
    const int line = static_cast<int>(std::count(text.begin(), text.begin() + at + 1, '\n')) + 1;
    try {
      ParseSettings(text, "bad.yaml");
      ADD_FAILURE() << line_text << " accepted";
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("bad.yaml:" + std::to_string(line) + ": key '" + key + "'"),
                std::string::npos)
          << what;
      EXPECT_NE(what.find("is out of range: expected"), std::string::npos) << what;
    }
  }
  // The shipped values pass.
  EXPECT_NO_THROW(ParseSettings(bonn, "bonn.yaml"));
}

}  // namespace
}  // namespace dygslam
