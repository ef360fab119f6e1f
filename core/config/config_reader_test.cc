#include "core/config/config_reader.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "tests/support/test_support.h"

namespace dygslam {
namespace {

// Expects an InputError whose message contains every needle.
template <typename F>
void ExpectInputError(F&& f, std::initializer_list<std::string> needles) {
  try {
    f();
    ADD_FAILURE() << "expected InputError";
  } catch (const InputError& e) {
    for (const std::string& n : needles) {
      EXPECT_NE(std::string(e.what()).find(n), std::string::npos)
          << "'" << n << "' not in: " << e.what();
    }
  }
}

const char* kOpenCvStyle = R"(%YAML:1.0
---
# comment
Camera.fx: 517.306408
Camera.k1: -0.25
Camera.width: 640
Camera.RGB: 1
ORBextractor:
  nFeatures: 1000
  scaleFactor: 1.2
Flags.enabled: true
Names: [person, "car", dog]
DynamicFilter:
  threshold: 0.7
  Inner:
    depth: 3
DynamicFilter.flat: 5
K: !!opencv-matrix
   rows: 2
   cols: 2
   dt: d
   data: [ 1., 2., 3., 4. ]
Empty:
)";

TEST(ConfigReader, ReadsFlatNestedAndOpenCvStyle) {
  const ConfigReader r = ConfigReader::FromString(kOpenCvStyle, "test.yaml");
  EXPECT_EQ(r.Require<double>("Camera.fx"), 517.306408);
  EXPECT_EQ(r.Require<double>("Camera.k1"), -0.25);
  EXPECT_EQ(r.Require<int>("Camera.width"), 640);
  EXPECT_EQ(r.Require<int>("ORBextractor.nFeatures"), 1000);
  EXPECT_DOUBLE_EQ(r.Section("ORBextractor").Require<double>("scaleFactor"), 1.2);
  EXPECT_TRUE(r.Require<bool>("Flags.enabled"));
  EXPECT_TRUE(r.Require<bool>("Camera.RGB"));
  EXPECT_EQ(r.Require<std::vector<std::string>>("Names"),
            (std::vector<std::string>{"person", "car", "dog"}));
  EXPECT_EQ(r.Require<std::vector<double>>("K"), (std::vector<double>{1, 2, 3, 4}));
  EXPECT_EQ(r.Require<std::string>("Camera.fx"), "517.306408");
  // Sections: nested and flat entries, nested sections.
  const ConfigReader dyn = r.Section("DynamicFilter");
  EXPECT_EQ(dyn.prefix(), "DynamicFilter");
  EXPECT_DOUBLE_EQ(dyn.Require<double>("threshold"), 0.7);
  EXPECT_EQ(dyn.Require<int>("flat"), 5);
  EXPECT_EQ(dyn.Section("Inner").Require<int>("depth"), 3);
  EXPECT_EQ(r.Require<int>("DynamicFilter.Inner.depth"), 3);
  // Optional keys.
  EXPECT_EQ(r.Get<int>("Camera.height", 480), 480);
  EXPECT_EQ(r.Get<double>("Empty", 2.5), 2.5);
  EXPECT_FALSE(r.Has("Empty"));
  EXPECT_TRUE(r.Has("Camera.fx"));
  EXPECT_FALSE(r.Has("Camera.fy"));
  int value = 17;
  EXPECT_FALSE(r.ReadIfPresent("Nope", &value));
  EXPECT_EQ(value, 17);
  EXPECT_EQ(r.LineOf("Camera.fx"), 4);
  EXPECT_EQ(r.LineOf("ORBextractor.scaleFactor"), 10);
  EXPECT_EQ(r.LineOf("Camera.fy"), 0);
  const std::vector<std::string> keys = dyn.Keys();
  EXPECT_EQ(keys, (std::vector<std::string>{"DynamicFilter.threshold", "DynamicFilter.Inner.depth",
                                            "DynamicFilter.flat"}));
}

TEST(ConfigReader, MissingRequiredKeyNamesKeyAndFile) {
  const ConfigReader r = ConfigReader::FromString("Camera.fx: 1\nEmpty:\n", "cam.yaml");
  ExpectInputError([&] { r.Require<double>("Camera.fy"); },
                   {"cam.yaml", "missing required key 'Camera.fy'"});
  ExpectInputError([&] { r.Require<double>("Empty"); }, {"cam.yaml:2", "'Empty'", "no value"});
  ExpectInputError([&] { r.Section("Camera").Require<double>("cx"); }, {"'Camera.cx'"});
}

TEST(ConfigReader, BadValuesNameKeyAndLine) {
  const ConfigReader r = ConfigReader::FromString(
      "a: 1\nCamera.fx: abc\nnan_value: .nan\ninf_value: -.inf\nplain_nan: nan\n"
      "i: 3.5\nbig: 99999999999\nflag: maybe\nlist: {x: 1}\nhuge: 1e999\n",
      "bad.yaml");
  ExpectInputError([&] { r.Require<double>("Camera.fx"); },
                   {"bad.yaml:2", "'Camera.fx'", "expected a number"});
  ExpectInputError([&] { r.Get<double>("Camera.fx", 1.0); }, {"bad.yaml:2", "'Camera.fx'"});
  ExpectInputError([&] { r.Require<double>("nan_value"); },
                   {"bad.yaml:3", "'nan_value'", "finite"});
  ExpectInputError([&] { r.Require<double>("inf_value"); }, {"bad.yaml:4", "finite"});
  ExpectInputError([&] { r.Require<float>("plain_nan"); }, {"bad.yaml:5", "finite"});
  ExpectInputError([&] { r.Require<int>("i"); }, {"bad.yaml:6", "'i'", "expected an integer"});
  ExpectInputError([&] { r.Require<int>("big"); }, {"bad.yaml:7", "out of range"});
  EXPECT_EQ(r.Require<int64_t>("big"), 99999999999LL);
  ExpectInputError([&] { r.Require<bool>("flag"); }, {"bad.yaml:8", "'flag'", "true/false"});
  ExpectInputError([&] { r.Require<double>("list"); }, {"bad.yaml:9", "found a map"});
  ExpectInputError([&] { r.Require<double>("huge"); }, {"bad.yaml:10", "finite"});
  ExpectInputError([&] { r.Fail("a", "custom problem"); },
                   {"bad.yaml:1", "key 'a': custom problem"});
}

TEST(ConfigReader, KeyGivenTwiceIsAnError) {
  const ConfigReader r = ConfigReader::FromString("Camera.fx: 1\nCamera:\n  fx: 2\n", "dup.yaml");
  ExpectInputError([&] { r.Require<double>("Camera.fx"); },
                   {"dup.yaml:3", "more than once", "line 1"});
}

TEST(ConfigReader, MalformedYamlNamesLine) {
  ExpectInputError([] { ConfigReader::FromString("a: 1\nb: [1, 2\nc: 3\n", "broken.yaml"); },
                   {"broken.yaml:", "malformed YAML"});
  ExpectInputError([] { ConfigReader::FromString("a: 1\n  b: 2\n", "indent.yaml"); },
                   {"indent.yaml:2", "malformed YAML"});
  ExpectInputError([] { ConfigReader::FromString("- 1\n- 2\n", "list.yaml"); },
                   {"list.yaml:1", "top level"});
  EXPECT_FALSE(ConfigReader::FromString("", "empty.yaml").Has("x"));
}

TEST(ConfigReader, FileErrors) {
  ExpectInputError([] { ConfigReader::FromFile("/nonexistent/settings.yaml"); },
                   {"/nonexistent/settings.yaml", "not found"});
  const std::string dir = testing::MakeTempDir("config");
  ExpectInputError([&] { ConfigReader::FromFile(dir); }, {"is a directory"});
  std::ofstream(dir + "/s.yaml") << "%YAML:1.0\nx: 2\ny: [\n";
  ExpectInputError([&] { ConfigReader::FromFile(dir + "/s.yaml"); },
                   {dir + "/s.yaml:", "malformed"});
}

struct ThresholdOptions {
  double threshold = 0.5;
  void Check() const {
    DYGSLAM_CHECK_OPTION(threshold > 0 && threshold < 1, "DynamicFilter.threshold");
  }
};

TEST(ConfigReader, CheckOptionsNamesFileLineAndKey) {
  const ConfigReader r =
      ConfigReader::FromString("x: 0\nDynamicFilter:\n  threshold: 1.5\n", "opts.yaml");
  ThresholdOptions o;
  const ConfigReader s = r.Section("DynamicFilter");
  EXPECT_TRUE(s.ReadIfPresent("threshold", &o.threshold));
  ExpectInputError([&] { s.CheckOptions(o); }, {"opts.yaml:3", "DynamicFilter.threshold"});
  o.threshold = 0.3;
  EXPECT_NO_THROW(s.CheckOptions(o));
}

}  // namespace
}  // namespace dygslam
