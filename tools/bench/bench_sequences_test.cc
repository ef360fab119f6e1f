#include "tools/bench/bench_sequences.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "core/base/error.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

void Touch(const fs::path& p) {
  fs::create_directories(p.parent_path());
  std::ofstream(p) << "# test\n";
}

void MakeSequence(const fs::path& dir, bool groundtruth) {
  Touch(dir / "rgb.txt");
  Touch(dir / "depth.txt");
  if (groundtruth) Touch(dir / "groundtruth.txt");
}

TEST(BenchSequences, FindsTumAndBonnLayoutsNestedAndSorted) {
  const fs::path root = testing::MakeTempDir("bench_seq");
  MakeSequence(root / "rgbd_bonn_crowd", true);
  MakeSequence(root / "tum" / "rgbd_dataset_freiburg3_walking_xyz", true);
  MakeSequence(root / "tum" / "rgbd_dataset_freiburg1_xyz", true);
  MakeSequence(root / "no_gt", false);
  Touch(root / "generated" / "camera.yaml");
  MakeSequence(root / "generated", true);
  fs::create_directories(root / "empty");
  std::vector<std::string> skipped;
  const auto seqs = FindBenchSequences(root.string(), "/cfg", "", &skipped);
  ASSERT_EQ(seqs.size(), 4u);
  EXPECT_EQ(seqs[0].name, "generated");
  EXPECT_EQ(seqs[0].settings_path, (root / "generated" / "camera.yaml").string());
  EXPECT_EQ(seqs[1].name, "rgbd_bonn_crowd");
  EXPECT_EQ(seqs[1].settings_path, "/cfg/bonn.yaml");
  EXPECT_EQ(seqs[2].name, "rgbd_dataset_freiburg1_xyz");
  EXPECT_EQ(seqs[2].settings_path, "/cfg/tum1.yaml");
  EXPECT_EQ(seqs[3].name, "rgbd_dataset_freiburg3_walking_xyz");
  EXPECT_EQ(seqs[3].settings_path, "/cfg/tum3.yaml");
  EXPECT_EQ(seqs[3].directory, (root / "tum" / "rgbd_dataset_freiburg3_walking_xyz").string());
  ASSERT_EQ(skipped.size(), 1u);
  EXPECT_NE(skipped[0].find("no_gt"), std::string::npos);
  EXPECT_NE(skipped[0].find("groundtruth.txt"), std::string::npos);

  // A sequence folder itself (trailing slash too); an override wins over presets.
  const auto one =
      FindBenchSequences((root / "rgbd_bonn_crowd").string() + "/", "/cfg", "/my.yaml");
  ASSERT_EQ(one.size(), 1u);
  EXPECT_EQ(one[0].name, "rgbd_bonn_crowd");
  EXPECT_EQ(one[0].settings_path, "/my.yaml");
  // Depth limit.
  EXPECT_EQ(FindBenchSequences(root.string(), "/cfg", "", nullptr, 1).size(), 2u);
}

TEST(BenchSequences, NotADirectoryNamesThePath) {
  try {
    FindBenchSequences("/nonexistent/dygslam_data", "/cfg");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/dygslam_data: not a directory"),
              std::string::npos);
  }
}

TEST(BenchSequences, DefaultSettingsPresetByName) {
  EXPECT_EQ(DefaultSettingsPath("/d/rgbd_dataset_freiburg2_desk_with_person", "/c"),
            "/c/tum2.yaml");
  EXPECT_EQ(DefaultSettingsPath("/d/bonn_crowd_part/", "/c"), "/c/bonn.yaml");
}

}  // namespace
}  // namespace dygslam
