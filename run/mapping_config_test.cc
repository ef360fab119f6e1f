#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "core/config/settings.h"
#include "mapping/octomap_settings.h"
#include "run/settings_table.h"

namespace dygslam {
namespace {

std::string ErrorOf(const std::string& yaml) {
  try {
    OctoMapOptions options;
    ReadOptions(ConfigReader::FromString(yaml, "map.yaml"), &options);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(MappingConfig, AbsentSectionKeepsDefaults) {
  OctoMapOptions options;
  ReadOptions(ConfigReader::FromString("Camera.fx: 500\n", "map.yaml"), &options);
  const OctoMapOptions defaults;
  EXPECT_EQ(options.resolution, defaults.resolution);
  EXPECT_EQ(options.max_range, defaults.max_range);
  EXPECT_EQ(options.prob_hit, defaults.prob_hit);
  EXPECT_EQ(options.use_dynamic_mask, defaults.use_dynamic_mask);
  // The "sensible defaults" for Kinect-class sensors.
  EXPECT_DOUBLE_EQ(defaults.resolution, 0.05);
  EXPECT_DOUBLE_EQ(defaults.max_range, 4.0);
}

TEST(MappingConfig, ReadsNestedAndFlatKeys) {
  OctoMapOptions options;
  ReadOptions(ConfigReader::FromString("OctoMap:\n"
                                       "  resolution: 0.1\n"
                                       "  max_range: 3.5\n"
                                       "  prob_hit: 0.8\n"
                                       "  prob_miss: 0.3\n"
                                       "  clamping_min: 0.1\n"
                                       "  clamping_max: 0.95\n"
                                       "  pixel_stride: 4\n"
                                       "  use_dynamic_mask: false\n"
                                       "  dynamic_mask_dilation_px: 9\n"
                                       "OctoMap.min_range: 0.5\n",
                                       "map.yaml"),
              &options);
  EXPECT_DOUBLE_EQ(options.resolution, 0.1);
  EXPECT_DOUBLE_EQ(options.max_range, 3.5);
  EXPECT_DOUBLE_EQ(options.min_range, 0.5);
  EXPECT_DOUBLE_EQ(options.prob_hit, 0.8);
  EXPECT_DOUBLE_EQ(options.prob_miss, 0.3);
  EXPECT_DOUBLE_EQ(options.clamping_min, 0.1);
  EXPECT_DOUBLE_EQ(options.clamping_max, 0.95);
  EXPECT_EQ(options.pixel_stride, 4);
  EXPECT_FALSE(options.use_dynamic_mask);
  EXPECT_EQ(options.dynamic_mask_dilation_px, 9);
  EXPECT_TRUE(options.use_voxel_filter);  // untouched
}

TEST(MappingConfig, BadValuesNameFileLineAndKey) {
  // prob_hit must be a hit (> 0.5): line 3.
  const std::string e1 = ErrorOf("OctoMap:\n  resolution: 0.05\n  prob_hit: 0.4\n");
  EXPECT_NE(e1.find("map.yaml:3"), std::string::npos) << e1;
  EXPECT_NE(e1.find("OctoMap.prob_hit"), std::string::npos) << e1;
  // Not a number.
  const std::string e2 = ErrorOf("OctoMap:\n  resolution: fine\n");
  EXPECT_NE(e2.find("map.yaml:2"), std::string::npos) << e2;
  EXPECT_NE(e2.find("OctoMap.resolution"), std::string::npos) << e2;
  // Negative resolution.
  const std::string e3 = ErrorOf("OctoMap.resolution: -1\n");
  EXPECT_NE(e3.find("OctoMap.resolution"), std::string::npos) << e3;
}

// A misspelt OctoMap key is what a misspelt key of any section is (not an error here
// while LoadSettings warns): a warning naming file:line and the closest known key, an
// error only with UnknownKeyPolicy::kError (--strict-settings). A wrong type stays an error.
TEST(MappingConfig, MisspeltKeyWarnsLikeEverySection) {
  const std::string camera =
      "Camera:\n  fx: 500\n  fy: 500\n  cx: 320\n  cy: 240\n  k1: 0\n  k2: 0\n  p1: 0\n  p2: 0\n";
  const std::string yaml = camera + "OctoMap:\n  resolution: 0.05\n  max_rnage: 3\n";
  const Settings settings = ParseSettings(yaml, "map.yaml");
  ASSERT_EQ(settings.warnings.size(), 1u);
  EXPECT_NE(settings.warnings[0].find("map.yaml:12: unknown key 'OctoMap.max_rnage' (did you mean "
                                      "'OctoMap.max_range'?)"),
            std::string::npos)
      << settings.warnings[0];
  OctoMapOptions options;
  EXPECT_NO_THROW(ReadOptions(settings.reader, &options));
  EXPECT_EQ(options.resolution, 0.05);
  try {
    ParseSettings(yaml, "map.yaml", {UnknownKeyPolicy::kError, false});
    ADD_FAILURE() << "unknown key accepted with kError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("map.yaml:12:"), std::string::npos) << e.what();
  }
  const std::string e4 = ErrorOf(camera + "OctoMap:\n  max_range: far\n");
  EXPECT_NE(e4.find("map.yaml:11"), std::string::npos) << e4;
  EXPECT_NE(e4.find("OctoMap.max_range"), std::string::npos) << e4;
}

// The shipped presets hold the sensor only: the mapper reading one gets its defaults, and the
// same preset with an OctoMap section appended gets that section's values.
TEST(MappingConfig, PresetsLeaveTheMapperDefaults) {
  const OctoMapOptions defaults;
  for (const char* name : {"bonn.yaml", "tum1.yaml", "tum2.yaml", "tum3.yaml"}) {
    const std::string path = std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/" + name;
    const Settings settings = LoadSettings(path);
    EXPECT_FALSE(settings.reader.Has("OctoMap.resolution")) << path;
    OctoMapOptions options;
    ASSERT_NO_THROW(ReadOptions(settings.reader, &options)) << path;
    EXPECT_EQ(options.resolution, defaults.resolution) << path;
    EXPECT_EQ(options.max_range, defaults.max_range) << path;
    EXPECT_EQ(options.pixel_stride, defaults.pixel_stride) << path;
    std::ifstream in(path);
    std::stringstream text;
    text << in.rdbuf();
    const Settings with_section =
        ParseSettings(text.str() + "OctoMap:\n  resolution: 0.1\n  pixel_stride: 4\n", path);
    OctoMapOptions set;
    ASSERT_NO_THROW(ReadOptions(with_section.reader, &set)) << path;
    EXPECT_EQ(set.resolution, 0.1) << path;
    EXPECT_EQ(set.pixel_stride, 4) << path;
    EXPECT_EQ(set.max_range, defaults.max_range) << path;
  }
}

}  // namespace
}  // namespace dygslam
