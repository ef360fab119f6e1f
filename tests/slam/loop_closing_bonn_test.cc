// Loop acceptance on real frames: bonn_crowd_part never leaves one spot of the room
// (1.0 m of camera path in 360 frames, people walking through the view), so the index offers
// consistent loop candidates all along, and before the acceptance checks were made stricter one of
// them was accepted with a 0.8 m correction. With loop closing on, no loop may be accepted and the
// trajectory must be the one of a run with loop closing off (deterministic mode: bit for bit).
#include <gtest/gtest.h>

#include "core/config/settings.h"
#include "core/eval/trajectory_eval.h"
#include "core/io/dataset.h"
#include "core/io/trajectory_io.h"
#include "core/system/system.h"
#include "run/settings_table.h"
#include "run/system_config.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {

struct BonnRun {
  std::vector<StampedPose> trajectory;
  LoopClosingStats loops;
};

BonnRun RunBonn(const std::string& dir, bool loops_enabled) {
  const Settings settings =
      LoadSettings(std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/bonn.yaml");
  SystemOptions options = SystemOptionsFromSettings(settings);
  options.filter.mode = FilterMode::kFull;
  options.deterministic = true;
  options.loop_closing.enabled = loops_enabled;
  System system(options);
  const RgbdDataset dataset = RgbdDataset::Open(dir);
  for (size_t k = 0; k < dataset.num_rgb_entries(); ++k) {
    const auto i = dataset.FrameForRgbEntry(k);
    if (!i) continue;
    system.FeedRgbdFrame(dataset.LoadRgb(*i), dataset.LoadDepth(*i), dataset.frame(*i).rgb_stamp);
  }
  system.Shutdown();
  return {system.Trajectory(), system.LoopClosingStatistics()};
}

TEST(LoopClosingBonn, NoLoopAcceptedAndTrajectoryUnchanged) {
  DYGSLAM_REQUIRE_DATASET(dir, "bonn_crowd_part");
  const BonnRun on = RunBonn(dir, true);
  const BonnRun off = RunBonn(dir, false);
  const auto gt = ReadTumTrajectory(dir + "/groundtruth.txt");
  const double ate_on = ComputeAte(gt, on.trajectory).error.rmse;
  const double ate_off = ComputeAte(gt, off.trajectory).error.rmse;
  const LoopClosingStats& s = on.loops;
  std::printf(
      "bonn_crowd_part full, loop closing on: %d keyframes checked, %d consistent candidates, "
      "%d verified (rejected: %d inliers, %d ratio, %d implausible, %d guided), %d loops; ATE on "
      "%.4f m, off %.4f m\n",
      s.keyframes_checked, s.candidates_detected, static_cast<int>(s.verifications.size()),
      s.rejected_inliers, s.rejected_ratio, s.rejected_implausible, s.rejected_projection,
      s.loops_closed, ate_on, ate_off);
  for (const LoopVerification& v : s.verifications)
    std::printf(
        "  frame %lld vs %lld: %d / %d inliers, %d matches, %.3f m / %.2f deg (budget %.3f m "
        "/ %.2f deg over %.3f m): %s\n",
        static_cast<long long>(v.frame_id), static_cast<long long>(v.loop_frame_id), v.inliers,
        v.bow_pairs, v.projected, v.correction_m, v.correction_deg, v.allowed_m, v.allowed_deg,
        v.path_m, v.verdict);
  // Every keyframe went through loop detection. (The index proposes no consistent candidate on
  // this sequence since keyframes are no longer made on every frame with people close: 45
  // keyframes, 0 candidates; with 51 it proposed some, all rejected. The verification steps are
  // exercised on the generated loops: tests/slam/loop_closing_test.cc, loop_correction_test.cc.)
  EXPECT_GE(s.keyframes_checked, 40);
  EXPECT_EQ(s.loops_closed, 0);
  ASSERT_EQ(on.trajectory.size(), off.trajectory.size());
  for (size_t i = 0; i < on.trajectory.size(); ++i) {
    EXPECT_EQ(on.trajectory[i].stamp, off.trajectory[i].stamp);
    EXPECT_EQ(on.trajectory[i].world_from_cam.translation,
              off.trajectory[i].world_from_cam.translation);
  }
  EXPECT_EQ(ate_on, ate_off);
}

}  // namespace
}  // namespace dygslam
