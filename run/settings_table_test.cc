#include "run/settings_table.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <string>

#include "core/config/settings.h"

namespace dygslam {
namespace {

std::string PresetPath(const std::string& name) {
  const char* src = std::getenv("DYGSLAM_SOURCE_DIR");
  return std::string(src ? src : ".") + "/config/" + name;
}

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

TEST(Settings, PresetsLoad) {
  const Settings tum1 = LoadSettings(PresetPath("tum1.yaml"));
  EXPECT_EQ(tum1.camera.fx, 517.306408);
  EXPECT_EQ(tum1.camera.cy, 255.313989);
  EXPECT_EQ(tum1.camera.k3, 1.163314);
  EXPECT_EQ(tum1.path, PresetPath("tum1.yaml"));
  const Settings tum2 = LoadSettings(PresetPath("tum2.yaml"));
  EXPECT_EQ(tum2.camera.fy, 521.007327);
  EXPECT_EQ(tum2.camera.p2, -0.000105);
  const Settings tum3 = LoadSettings(PresetPath("tum3.yaml"));
  EXPECT_EQ(tum3.camera.fx, 535.4);
  EXPECT_FALSE(tum3.camera.HasDistortion());
  const Settings bonn = LoadSettings(PresetPath("bonn.yaml"));
  EXPECT_EQ(bonn.camera.fx, 542.822841);
  EXPECT_EQ(bonn.camera.cx, 315.593520);
  EXPECT_EQ(bonn.camera.k2, -0.099343);
  for (const Settings* s : {&tum1, &tum2, &tum3, &bonn}) {
    EXPECT_EQ(s->camera.width, 640);
    EXPECT_EQ(s->camera.height, 480);
    EXPECT_EQ(s->sensor.fps, 30.0);
    EXPECT_EQ(s->sensor.bf, 40.0);
    EXPECT_EQ(s->sensor.th_depth, 40.0);
    EXPECT_EQ(s->sensor.depth_map_factor, 5000.0);
    EXPECT_EQ(s->orb.num_features, 1000);
    EXPECT_EQ(s->orb.scale_factor, 1.2);
    EXPECT_EQ(s->orb.num_levels, 8);
    EXPECT_EQ(s->orb.ini_th_fast, 20);
    EXPECT_EQ(s->orb.min_th_fast, 7);
    EXPECT_EQ(s->reader.path(), s->path);
  }
}

const std::string kMinimal =
    "%YAML:1.0\nCamera.fx: 500\nCamera.fy: 501\nCamera.cx: 320\nCamera.cy: 240\n"
    "Camera.k1: 0\nCamera.k2: 0\nCamera.p1: 0\nCamera.p2: 0\n";

TEST(Settings, DefaultsForOptionalKeysAndNestedForm) {
  const Settings s = ParseSettings(kMinimal, "min.yaml");
  EXPECT_EQ(s.camera.k3, 0);
  EXPECT_EQ(s.camera.width, 640);
  EXPECT_EQ(s.sensor.depth_map_factor, 5000);
  EXPECT_EQ(s.orb.num_features, 1000);
  const Settings nested = ParseSettings(
      "Camera:\n  fx: 500\n  fy: 501\n  cx: 320\n  cy: 240\n  k1: 0.1\n  k2: 0\n  p1: 0\n  p2: 0\n"
      "  width: 320\n  height: 240\nORBextractor:\n  nFeatures: 500\n",
      "nested.yaml");
  EXPECT_EQ(nested.camera.k1, 0.1);
  EXPECT_EQ(nested.camera.width, 320);
  EXPECT_EQ(nested.orb.num_features, 500);
}

TEST(Settings, ErrorsNameFileLineAndKey) {
  // Missing required key.
  std::string missing = kMinimal;
  missing.replace(missing.find("Camera.cy: 240\n"), 15, "");
  ExpectInputError([&] { ParseSettings(missing, "m.yaml"); }, {"m.yaml", "Camera.cy"});
  // Non-numeric value.
  ExpectInputError([&] { ParseSettings(kMinimal + "Camera.bf: forty\n", "n.yaml"); },
                   {"n.yaml:10", "Camera.bf", "expected a number"});
  // NaN.
  ExpectInputError([&] { ParseSettings(kMinimal + "DepthMapFactor: .nan\n", "nan.yaml"); },
                   {"nan.yaml:10", "DepthMapFactor", "finite"});
  // Malformed YAML.
  ExpectInputError([&] { ParseSettings(kMinimal + "ORBextractor.nFeatures: [1000\n", "bad.yaml"); },
                   {"bad.yaml:", "malformed YAML"});
  // Value that fails Check(): the line of the key and the key.
  ExpectInputError([&] { ParseSettings(kMinimal + "ORBextractor.minThFAST: 30\n", "c.yaml"); },
                   {"c.yaml:10", "ORBextractor.minThFAST"});
  std::string negative = kMinimal;
  negative.replace(negative.find("Camera.fx: 500"), 14, "Camera.fx: -5");
  ExpectInputError([&] { ParseSettings(negative, "f.yaml"); }, {"f.yaml:2", "Camera.fx"});
  ExpectInputError([&] { ParseSettings(kMinimal + "ORBextractor.nLevels: 8.5\n", "i.yaml"); },
                   {"i.yaml:10", "ORBextractor.nLevels", "integer"});
  ExpectInputError([] { LoadSettings("/nonexistent.yaml"); }, {"/nonexistent.yaml", "not found"});
}

}  // namespace
}  // namespace dygslam
