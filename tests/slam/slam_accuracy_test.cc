// SLAM accuracy and determinism on generated and real data (issue acceptance figures).
#include <gtest/gtest.h>

#include "core/config/settings.h"
#include "core/eval/trajectory_eval.h"
#include "core/io/dataset.h"
#include "core/io/trajectory_io.h"
#include "core/system/system.h"
#include "run/settings_table.h"
#include "run/system_config.h"
#include "tests/support/test_support.h"
#include "tools/synth/synthetic_scene.h"

namespace dygslam {
namespace {

struct RunOutput {
  std::vector<StampedPose> trajectory;
  int lost = 0;
};

RunOutput RunSynthetic(const SyntheticOptions& synth, FilterMode mode, bool use_boxes,
                       bool local_ba_pose_prior = true) {
  SyntheticScene scene(synth);
  SystemOptions options;
  options.camera = synth.camera;
  options.sensor = synth.sensor;
  options.filter.mode = mode;
  options.deterministic = true;
  options.local_mapping.optimizer.local_ba_pose_prior = local_ba_pose_prior;
  System system(options);
  RunOutput out;
  for (int i = 0; i < scene.num_frames(); ++i) {
    const SyntheticFrame f = scene.RenderFrame(i);
    const FrameResult r =
        system.FeedRgbdFrame(f.rgb, f.depth, f.stamp, cv::Mat(), use_boxes ? &f.boxes : nullptr);
    if (r.state == TrackingState::kLost) ++out.lost;
  }
  system.Shutdown();
  out.trajectory = system.Trajectory();
  return out;
}

std::vector<StampedPose> GroundTruth(const SyntheticOptions& synth) {
  SyntheticScene scene(synth);
  std::vector<StampedPose> gt;
  for (int i = 0; i < scene.num_frames(); ++i)
    gt.push_back(StampedPose{scene.FrameStamp(i), scene.WorldFromCam(i)});
  return gt;
}

TEST(SlamAccuracy, GeneratedStaticSequenceWithin5mm) {
  SyntheticOptions synth;
  synth.num_frames = 90;
  synth.num_moving_objects = 0;
  synth.seed = 7;
  const RunOutput run = RunSynthetic(synth, FilterMode::kNone, false);
  EXPECT_EQ(run.lost, 0);
  ASSERT_EQ(static_cast<int>(run.trajectory.size()), synth.num_frames);
  const AteResult ate = ComputeAte(GroundTruth(synth), run.trajectory);
  std::cout << "generated static sequence: ATE RMSE " << ate.error.rmse << " m over "
            << ate.num_pairs << " frames\n";
  EXPECT_LE(ate.error.rmse, 0.005);
}

TEST(SlamAccuracy, GeneratedDynamicSequenceFilterBeatsNoFilter) {
  SyntheticOptions synth;
  synth.num_frames = 90;
  synth.num_moving_objects = 3;
  synth.seed = 11;
  const auto gt = GroundTruth(synth);
  const RunOutput none = RunSynthetic(synth, FilterMode::kNone, false);
  const RunOutput full = RunSynthetic(synth, FilterMode::kFull, true);
  const double ate_none = ComputeAte(gt, none.trajectory).error.rmse;
  const double ate_full = ComputeAte(gt, full.trajectory).error.rmse;
  std::cout << "generated dynamic sequence: ATE none " << ate_none << " m, full " << ate_full
            << " m\n";
  EXPECT_LE(ate_full, 0.01);
  EXPECT_LE(ate_full, ate_none);
}

// The walker sequences: 150 frames of a static textured room with depth and colour noise (seed 1);
// AddWalker puts a walker covering `coverage` of the view for 30 frames from entry 60.
SyntheticOptions WalkerSequence() {
  SyntheticOptions synth;
  synth.num_frames = 150;
  synth.num_moving_objects = 0;
  synth.depth_noise = true;
  synth.rgb_noise_sigma = 2.0;
  synth.seed = 1;
  return synth;
}

void AddWalker(double coverage, SyntheticOptions* synth) {
  synth->occluder_coverage = coverage;
  synth->occluder_start_frame = 60;
  synth->occluder_frames = 30;
}

// A walker 0.9 m in front of the camera covers 80 % of the view (a box given) for 1 s: the static
// features left lie in a strip at one depth, where yaw and sideways translation explain the same
// image motion. The local BA's pose prior keeps the keyframes of the stretch where tracking put
// them; without it one BA slid a keyframe by 18 cm. Measured (this seed): ATE 3.6x the
// run without the walker with the prior, 12.3x without it.
TEST(SlamAccuracy, GeneratedWalkerCoveringMostOfTheViewKeepsTheKeyframesInPlace) {
  SyntheticOptions synth = WalkerSequence();
  const auto gt = GroundTruth(synth);
  const double ate_alone =
      ComputeAte(gt, RunSynthetic(synth, FilterMode::kFull, true).trajectory).error.rmse;
  AddWalker(0.8, &synth);
  const RunOutput with_prior = RunSynthetic(synth, FilterMode::kFull, true);
  const RunOutput without_prior = RunSynthetic(synth, FilterMode::kFull, true, false);
  const AteResult ate = ComputeAte(gt, with_prior.trajectory);
  const double ate_without_prior = ComputeAte(gt, without_prior.trajectory).error.rmse;
  std::cout << "walker covering 80 %: ATE " << ate.error.rmse << " m (" << ate.num_pairs
            << " frames with a pose), without the local BA prior " << ate_without_prior
            << " m, without the walker " << ate_alone << " m\n";
  EXPECT_EQ(ate.num_pairs, static_cast<size_t>(synth.num_frames));
  EXPECT_LE(ate.error.rmse, 7.0 * ate_alone);
  EXPECT_GT(ate_without_prior, 7.0 * ate_alone);
}

// A walker covering 95 % of the view for 1 s leaves a strip of static pixels a few dozen pixels
// wide: every frame gets a pose from the dense chain constrained by the motion model, including
// the frames where the walker enters and leaves the view (few feature inliers, a strip of static
// pixels seen in both frames), and the stretch is re-anchored on the first strong feature pose.
// Measured (this seed): ATE 2.1x the run without the walker (0.0082 m against 0.0040 m); 4.8x
// when the narrow view is judged by the current frame's static pixels alone and a weak feature
// pose ends the stretch.
TEST(SlamAccuracy, GeneratedWalkerFillingTheViewIsTrackedThroughTheStretch) {
  SyntheticOptions synth = WalkerSequence();
  const auto gt = GroundTruth(synth);
  const double ate_alone =
      ComputeAte(gt, RunSynthetic(synth, FilterMode::kFull, true).trajectory).error.rmse;
  AddWalker(0.95, &synth);
  const AteResult ate = ComputeAte(gt, RunSynthetic(synth, FilterMode::kFull, true).trajectory);
  std::cout << "walker covering 95 %: ATE " << ate.error.rmse << " m (" << ate.num_pairs
            << " frames with a pose), without the walker " << ate_alone << " m\n";
  EXPECT_EQ(ate.num_pairs, static_cast<size_t>(synth.num_frames));
  EXPECT_LE(ate.error.rmse, 3.0 * ate_alone);
}

// Blank frames (no texture, no depth) are reported lost without a pose; after a jump along the
// path the tracker relocalizes against the map instead of inventing a pose.
TEST(SlamRelocalization, LostFramesHaveNoPoseAndTrackingRecovers) {
  SyntheticOptions synth;
  synth.num_frames = 120;
  synth.num_moving_objects = 0;
  synth.seed = 5;
  SyntheticScene scene(synth);
  SystemOptions options;
  options.camera = synth.camera;
  options.sensor = synth.sensor;
  options.filter.mode = FilterMode::kNone;
  options.deterministic = true;
  System system(options);
  const cv::Mat blank_rgb(synth.camera.height, synth.camera.width, CV_8UC3,
                          cv::Scalar(128, 128, 128));
  const cv::Mat blank_depth(synth.camera.height, synth.camera.width, CV_16UC1, cv::Scalar(0));
  std::vector<int> fed;
  for (int i = 0; i < 60; ++i) fed.push_back(i);
  for (int i = 100; i < 120; ++i) fed.push_back(i);  // kidnapped: 40 frames later along the path
  int lost = 0, relocalized = 0, blanks = 0;
  int64_t fake_ns = 0;
  for (size_t n = 0; n < fed.size(); ++n) {
    if (n == 60) {
      for (int b = 0; b < 5; ++b) {
        const Timestamp t =
            Timestamp::FromNanoseconds(scene.FrameStamp(59).nanoseconds() + (++fake_ns) * 1000000);
        const FrameResult r = system.FeedRgbdFrame(blank_rgb, blank_depth, t);
        EXPECT_EQ(r.state, TrackingState::kLost);
        EXPECT_FALSE(r.world_from_cam.has_value());
        ++blanks;
      }
    }
    const SyntheticFrame f = scene.RenderFrame(fed[n]);
    const FrameResult r = system.FeedRgbdFrame(f.rgb, f.depth, f.stamp);
    if (r.state == TrackingState::kLost) {
      ++lost;
      EXPECT_FALSE(r.world_from_cam.has_value());
    }
    if (r.state == TrackingState::kRelocalized) ++relocalized;
  }
  system.Shutdown();
  EXPECT_EQ(blanks, 5);
  EXPECT_GE(relocalized, 1);
  EXPECT_LE(lost, 3);
  std::vector<StampedPose> gt;
  for (int i : fed) gt.push_back(StampedPose{scene.FrameStamp(i), scene.WorldFromCam(i)});
  const AteResult ate = ComputeAte(gt, system.Trajectory());
  std::cout << "kidnapped sequence: " << relocalized << " relocalized, " << lost << " lost, ATE "
            << ate.error.rmse << " m over " << ate.num_pairs << " poses\n";
  EXPECT_GE(ate.num_pairs, fed.size() - 3);
  EXPECT_LE(ate.error.rmse, 0.01);
}

RunOutput RunBonn(const std::string& dir, size_t first, size_t last, FilterMode mode) {
  const Settings settings =
      LoadSettings(std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/bonn.yaml");
  SystemOptions options = SystemOptionsFromSettings(settings);
  options.filter.mode = mode;
  options.deterministic = true;
  System system(options);
  const RgbdDataset dataset = RgbdDataset::Open(dir);
  RunOutput out;
  for (size_t k = first; k < last; ++k) {
    const auto i = dataset.FrameForRgbEntry(k);
    if (!i) continue;
    const FrameResult r = system.FeedRgbdFrame(dataset.LoadRgb(*i), dataset.LoadDepth(*i),
                                               dataset.frame(*i).rgb_stamp);
    if (r.state == TrackingState::kLost) ++out.lost;
  }
  system.Shutdown();
  out.trajectory = system.Trajectory();
  return out;
}

TEST(SlamAccuracy, BonnPeopleFreeFramesWithin12mm) {
  DYGSLAM_REQUIRE_DATASET(dir, "bonn_crowd_part");
  const RunOutput run = RunBonn(dir, 0, 100, FilterMode::kNone);
  EXPECT_EQ(run.lost, 0);
  const AteResult ate = ComputeAte(ReadTumTrajectory(dir + "/groundtruth.txt"), run.trajectory);
  std::cout << "bonn_crowd_part 0:100: ATE RMSE " << ate.error.rmse << " m\n";
  EXPECT_EQ(ate.num_pairs, 100u);
  EXPECT_LE(ate.error.rmse, 0.012);
}

TEST(SlamAccuracy, DeterministicModeIsRepeatable) {
  DYGSLAM_REQUIRE_DATASET(dir, "bonn_crowd_part");
  const RunOutput a = RunBonn(dir, 100, 160, FilterMode::kFull);
  const RunOutput b = RunBonn(dir, 100, 160, FilterMode::kFull);
  // Frames 100..159 (people entering) are all tracked in deterministic runs (60 poses, measured
  // 2026-12-01); an empty or mostly-lost run must not pass as "repeatable".
  std::cout << "bonn_crowd_part 100:160 full filter: " << a.trajectory.size() << " poses, "
            << a.lost << " lost\n";
  ASSERT_GE(a.trajectory.size(), 55u);
  ASSERT_EQ(a.trajectory.size(), b.trajectory.size());
  for (size_t i = 0; i < a.trajectory.size(); ++i) {
    EXPECT_EQ(a.trajectory[i].stamp, b.trajectory[i].stamp);
    EXPECT_EQ(a.trajectory[i].world_from_cam.translation,
              b.trajectory[i].world_from_cam.translation);
    EXPECT_EQ(a.trajectory[i].world_from_cam.rotation.coeffs(),
              b.trajectory[i].world_from_cam.rotation.coeffs());
  }
}

// The shipped defaults on real data (config/bonn.yaml holds the sensor only; deterministic runs
// equal threaded ones): full method within its measured figure and >= 10x better than no filter.
TEST(DynamicFilterAccuracy, BonnCrowdFullMethod) {
  DYGSLAM_REQUIRE_DATASET(dir, "bonn_crowd_part");
  const auto gt = ReadTumTrajectory(dir + "/groundtruth.txt");
  const RunOutput none = RunBonn(dir, 0, 360, FilterMode::kNone);
  const RunOutput full = RunBonn(dir, 0, 360, FilterMode::kFull);
  const double ate_none = ComputeAte(gt, none.trajectory).error.rmse;
  const AteResult ate_full = ComputeAte(gt, full.trajectory);
  std::cout << "bonn_crowd_part 360 frames: ATE none " << ate_none << " m, full "
            << ate_full.error.rmse << " m (" << ate_full.num_pairs << " tracked, " << full.lost
            << " lost)\n";
  // Measured 0.0146 m (spread 0 run to run); limit: + 3 x the spread of this ATE under neutral
  // changes (+-0.0007 m).
  EXPECT_LE(ate_full.error.rmse, 0.0167);
  EXPECT_GE(ate_none / ate_full.error.rmse, 10.0);
  // Every frame gets a pose (feature tracking, else the dense fallback): 360 of 360 with a pose,
  // 0 lost, in every deterministic run (spread 0).
  EXPECT_EQ(ate_full.num_pairs, 360u);
  EXPECT_EQ(full.lost, 0);
}

}  // namespace
}  // namespace dygslam
