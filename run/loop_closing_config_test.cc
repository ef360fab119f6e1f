// LoopClosing section: vocabulary resolution, the on/off switch, bad values named.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "core/config/settings.h"
#include "run/system_config.h"
#include "tests/support/settings_text.h"

namespace dygslam {
namespace {

std::string Preset() {
  const char* src = std::getenv("DYGSLAM_SOURCE_DIR");
  const std::string path = std::string(src ? src : ".") + "/config/bonn.yaml";
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return testing::WithoutSection(text.str(), "Tracking");  // the cases bring their own
}

SystemOptions Options(const std::string& section) {
  const char* src = std::getenv("DYGSLAM_SOURCE_DIR");
  // Named as if it were config/loops.yaml: relative vocabulary paths resolve against config/.
  return SystemOptionsFromSettings(ParseSettings(
      Preset() + "\n" + section, std::string(src ? src : ".") + "/config/loops.yaml"));
}

TEST(LoopClosingConfig, DefaultsUseTheShippedVocabulary) {
  const SystemOptions o = Options("");
  EXPECT_TRUE(o.loop_closing.enabled);  // on by default (BENCHMARKS.md)
  EXPECT_NE(o.loop_closing.vocabulary.find("vocabulary.dygvoc"), std::string::npos);
  std::ifstream file(o.loop_closing.vocabulary);
  EXPECT_TRUE(file.good()) << o.loop_closing.vocabulary;
  EXPECT_EQ(o.loop_closing.consistency, LoopClosingOptions{}.consistency);
}

TEST(LoopClosingConfig, SwitchOnOffAndNoVocabulary) {
  EXPECT_TRUE(Options("LoopClosing:\n  enabled: true\n").loop_closing.enabled);
  const SystemOptions off = Options("LoopClosing:\n  enabled: false\n  consistency: 4\n");
  EXPECT_FALSE(off.loop_closing.enabled);
  EXPECT_EQ(off.loop_closing.consistency, 4);
  EXPECT_FALSE(off.loop_closing.vocabulary.empty());  // relocalization still uses the index
  const SystemOptions none = Options("LoopClosing:\n  vocabulary: none\n");
  EXPECT_TRUE(none.loop_closing.vocabulary.empty());
}

TEST(LoopClosingConfig, KeyframeMapInlierFloorIsReadAndChecked) {
  EXPECT_EQ(Options("").tracking.keyframe_min_map_inliers,
            TrackingOptions{}.keyframe_min_map_inliers);
  EXPECT_EQ(Options("Tracking:\n  keyframe_min_map_inliers: 0\n").tracking.keyframe_min_map_inliers,
            0);
  try {
    Options("Tracking:\n  keyframe_min_map_inliers: -5\n");
    ADD_FAILURE() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("Tracking.keyframe_min_map_inliers"), std::string::npos)
        << e.what();
  }
}

TEST(LoopClosingConfig, MissingVocabularyAndBadValuesAreNamed) {
  try {
    Options("LoopClosing:\n  vocabulary: nowhere.dygvoc\n");
    ADD_FAILURE() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("LoopClosing.vocabulary"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("nowhere.dygvoc"), std::string::npos) << e.what();
  }
  try {
    Options("LoopClosing:\n  consistency: 0\n");
    ADD_FAILURE() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("LoopClosing.consistency"), std::string::npos) << e.what();
  }
  for (const char* key : {"min_inlier_ratio", "max_correction_m", "max_drift_per_meter",
                          "max_correction_deg", "max_drift_deg_per_meter",
                          "pose_graph_min_correction_m", "pose_graph_min_correction_deg"}) {
    try {
      Options(std::string("LoopClosing:\n  ") + key + ": -1\n");
      ADD_FAILURE() << "expected InputError for " << key;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(std::string("LoopClosing.") + key), std::string::npos)
          << e.what();
    }
  }
}

TEST(LoopClosingConfig, AcceptanceKeysAreReadAndKnown) {
  const SystemOptions o = Options(
      "LoopClosing:\n  min_ransac_inliers: 50\n  min_inlier_ratio: 0.5\n  max_correction_m: 0.2\n"
      "  max_drift_per_meter: 0.05\n  max_correction_deg: 4\n  max_drift_deg_per_meter: 1\n"
      "  revisit_min_path_m: 0\n  pose_graph_min_correction_m: 0.03\n"
      "  pose_graph_min_correction_deg: 0.5\n");
  EXPECT_EQ(o.loop_closing.min_ransac_inliers, 50);
  EXPECT_EQ(o.loop_closing.min_inlier_ratio, 0.5);
  EXPECT_EQ(o.loop_closing.max_correction_m, 0.2);
  EXPECT_EQ(o.loop_closing.max_drift_per_meter, 0.05);
  EXPECT_EQ(o.loop_closing.max_correction_deg, 4);
  EXPECT_EQ(o.loop_closing.max_drift_deg_per_meter, 1);
  EXPECT_EQ(o.loop_closing.revisit_min_path_m, 0);
  EXPECT_EQ(o.loop_closing.pose_graph_min_correction_m, 0.03);
  EXPECT_EQ(o.loop_closing.pose_graph_min_correction_deg, 0.5);
  // Every key of the section is a known settings key (no "unknown key" warning for them).
  for (const char* key : {"enabled", "min_ransac_inliers", "min_inlier_ratio", "max_correction_m",
                          "revisit_min_path_m", "global_ba_iterations",
                          "pose_graph_min_correction_m", "pose_graph_min_correction_deg"}) {
    const std::string full = std::string("LoopClosing.") + key;
    EXPECT_NE(std::find(KnownSettingsKeys().begin(), KnownSettingsKeys().end(), full),
              KnownSettingsKeys().end())
        << full;
  }
}

}  // namespace
}  // namespace dygslam
