// LoopClosing section: vocabulary resolution, the on/off switch, bad values named.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "core/config/settings.h"
#include "run/settings_table.h"
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
  const SystemOptions off = Options("LoopClosing:\n  enabled: false\n  max_correction_m: 0.25\n");
  EXPECT_FALSE(off.loop_closing.enabled);
  EXPECT_EQ(off.loop_closing.max_correction_m, 0.25);
  EXPECT_FALSE(off.loop_closing.vocabulary.empty());  // relocalization still uses the index
  const SystemOptions none = Options("LoopClosing:\n  vocabulary: none\n");
  EXPECT_TRUE(none.loop_closing.vocabulary.empty());
}

// Keys that are no longer settings (fixed parts of tracking, local mapping and loop closing) are
// not read: a file that sets them runs as one that does not (a warning names each).
TEST(LoopClosingConfig, KeysNoLongerReadLeaveTheOptionsAsTheyWere) {
  const SystemOptions defaults = Options("");
  const SystemOptions set = Options(
      "Tracking:\n  keyframe_min_map_inliers: 0\n  ref_ratio: 0.5\nLocalMapping:\n  "
      "ba_lag_frames: 4\nLoopClosing:\n  consistency: 9\n  ransac_threshold_px: 12\n");
  EXPECT_EQ(set.tracking.keyframe_min_map_inliers, defaults.tracking.keyframe_min_map_inliers);
  EXPECT_EQ(set.tracking.ref_ratio, defaults.tracking.ref_ratio);
  EXPECT_EQ(set.local_mapping.ba_lag_frames, defaults.local_mapping.ba_lag_frames);
  EXPECT_EQ(set.loop_closing.consistency, defaults.loop_closing.consistency);
  EXPECT_EQ(set.loop_closing.ransac_threshold_px, defaults.loop_closing.ransac_threshold_px);
}

TEST(LoopClosingConfig, MissingVocabularyAndBadValuesAreNamed) {
  try {
    Options("LoopClosing:\n  vocabulary: nowhere.dygvoc\n");
    ADD_FAILURE() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("LoopClosing.vocabulary"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("nowhere.dygvoc"), std::string::npos) << e.what();
  }
  for (const char* key : {"max_correction_m", "revisit_min_path_m"}) {
    for (const char* value : {".nan", "1e20"}) {
      try {
        Options(std::string("LoopClosing:\n  ") + key + ": " + value + "\n");
        ADD_FAILURE() << "expected InputError for " << key << " " << value;
      } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find(std::string("LoopClosing.") + key), std::string::npos)
            << e.what();
      }
    }
  }
}

TEST(LoopClosingConfig, AcceptanceKeysAreReadAndKnown) {
  const SystemOptions o = Options(
      "LoopClosing:\n  max_correction_m: 0.2\n  revisit_min_path_m: 0\n"
      "  global_bundle_adjustment: false\n");
  EXPECT_EQ(o.loop_closing.max_correction_m, 0.2);
  EXPECT_EQ(o.loop_closing.revisit_min_path_m, 0);
  EXPECT_FALSE(o.loop_closing.global_bundle_adjustment);
  // Every key of the section is a known settings key (no "unknown key" warning for them).
  for (const char* key : {"vocabulary", "enabled", "max_correction_m", "revisit_min_path_m",
                          "global_bundle_adjustment"}) {
    const std::string full = std::string("LoopClosing.") + key;
    EXPECT_NE(std::find(KnownSettingsKeys().begin(), KnownSettingsKeys().end(), full),
              KnownSettingsKeys().end())
        << full;
  }
}

}  // namespace
}  // namespace dygslam
