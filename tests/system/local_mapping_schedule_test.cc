// The local-mapping schedule (core/slam/local_mapping/local_mapping.h): a keyframe's local BA is solved on the
// mapping thread and lands at a fixed point of the frame sequence, so a threaded run gives the
// trajectory of the unthreaded (deterministic) run, whatever the threads' timing.
#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "core/system/system.h"
#include "tools/synth/synthetic_scene.h"

namespace dygslam {
namespace {

SyntheticOptions ScheduleScene() {
  SyntheticOptions synth;
  synth.num_frames = 90;
  synth.num_moving_objects = 0;
  synth.supersampling = 1;
  synth.seed = 3;
  synth.depth_noise = true;
  synth.path_amplitude = 0.4;
  synth.yaw_amplitude_deg = 15;
  return synth;
}

// The scene's camera, no filter: the schedule alone is under test.
SystemOptions ScheduleOptions(const SyntheticOptions& synth) {
  SystemOptions options;
  options.camera = synth.camera;
  options.sensor = synth.sensor;
  options.filter.mode = FilterMode::kNone;
  return options;
}

struct ScheduledRun {
  int keyframes = 0;
  std::vector<StampedPose> trajectory;
  LocalMappingStats stats;
};

ScheduledRun RunSystem(SystemOptions options, const std::vector<SyntheticFrame>& frames,
                 bool deterministic) {
  options.deterministic = deterministic;
  System system(options);
  ScheduledRun run;
  for (const SyntheticFrame& f : frames)
    run.keyframes += system.FeedRgbdFrame(f.rgb, f.depth, f.stamp).is_keyframe;
  system.Shutdown();
  run.trajectory = system.Trajectory();
  run.stats = system.LocalMappingStatistics();
  return run;
}

std::vector<SyntheticFrame> Frames(const SyntheticScene& scene, int num_frames) {
  std::vector<SyntheticFrame> frames;
  for (int i = 0; i < num_frames; ++i) frames.push_back(scene.RenderFrame(i));
  return frames;
}

// The same keyframes and bit-identical poses.
void ExpectSameRun(const ScheduledRun& a, const ScheduledRun& b) {
  EXPECT_EQ(a.keyframes, b.keyframes);
  ASSERT_EQ(a.trajectory.size(), b.trajectory.size());
  for (size_t i = 0; i < a.trajectory.size(); ++i) {
    ASSERT_EQ(a.trajectory[i].world_from_cam.translation, b.trajectory[i].world_from_cam.translation)
        << "frame " << i;
    ASSERT_EQ(a.trajectory[i].world_from_cam.rotation.coeffs(),
              b.trajectory[i].world_from_cam.rotation.coeffs())
        << "frame " << i;
  }
}

TEST(LocalMappingSchedule, ThreadedRunGivesTheDeterministicTrajectory) {
  const SyntheticOptions synth = ScheduleScene();
  const SyntheticScene scene(synth);
  const std::vector<SyntheticFrame> frames = Frames(scene, scene.num_frames());
  const SystemOptions options = ScheduleOptions(synth);
  ASSERT_GT(options.local_mapping.ba_lag_frames, 0) << "the default runs the BA on its thread";
  const ScheduledRun det = RunSystem(options, frames, /*deterministic=*/true);
  ASSERT_GE(det.keyframes, 4) << "too few keyframes to test the schedule";
  ASSERT_EQ(det.trajectory.size(), frames.size());
  EXPECT_EQ(det.stats.keyframes_processed, det.keyframes);
  for (int repeat = 0; repeat < 2; ++repeat) {
    const ScheduledRun threaded = RunSystem(options, frames, /*deterministic=*/false);
    ExpectSameRun(threaded, det);
    EXPECT_EQ(threaded.stats.keyframes_processed, threaded.keyframes);
  }
}

// A keyframe due on every frame (the map-point floor above any count): each keyframe comes before
// the previous one's BA is due, so every BA lands early, at the insertion of the next keyframe,
// usually before its solve is done. Still the deterministic trajectory.
TEST(LocalMappingSchedule, KeyframesBeforeTheDueFrameLandTheBaEarlyAndDeterministically) {
  const SyntheticOptions synth = ScheduleScene();
  const SyntheticScene scene(synth);
  const int num_frames = 30;
  const std::vector<SyntheticFrame> frames = Frames(scene, num_frames);
  SystemOptions options = ScheduleOptions(synth);
  options.tracking.keyframe_min_map_inliers = 1000000;
  const ScheduledRun det = RunSystem(options, frames, /*deterministic=*/true);
  EXPECT_GE(det.keyframes, num_frames / 2) << "the keyframe rule did not fire";
  EXPECT_GE(det.stats.early_landings, det.keyframes / 2);
  const ScheduledRun threaded = RunSystem(options, frames, /*deterministic=*/false);
  ExpectSameRun(threaded, det);
  EXPECT_EQ(threaded.stats.early_landings, det.stats.early_landings);
  EXPECT_EQ(threaded.trajectory.size(), static_cast<size_t>(num_frames));
}

// The lag is a real choice: landing the BA at once (0) and two frames later give different
// trajectories, and both are followed exactly by the threaded run.
TEST(LocalMappingSchedule, TheLagDecidesTheTrajectoryNotTheThreads) {
  const SyntheticOptions synth = ScheduleScene();
  const SyntheticScene scene(synth);
  const std::vector<SyntheticFrame> frames = Frames(scene, scene.num_frames());
  SystemOptions at_once = ScheduleOptions(synth);
  at_once.local_mapping.ba_lag_frames = 0;
  SystemOptions lagged = ScheduleOptions(synth);
  lagged.local_mapping.ba_lag_frames = 2;
  const ScheduledRun a = RunSystem(at_once, frames, false), b = RunSystem(lagged, frames, false);
  ExpectSameRun(a, RunSystem(at_once, frames, true));
  double max_diff_m = 0;
  ASSERT_EQ(a.trajectory.size(), b.trajectory.size());
  for (size_t i = 0; i < a.trajectory.size(); ++i)
    max_diff_m = std::max(max_diff_m, (a.trajectory[i].world_from_cam.translation -
                                       b.trajectory[i].world_from_cam.translation)
                                          .norm());
  EXPECT_GT(max_diff_m, 0.0) << "the lag changed nothing: the BA does not land where scheduled";
}

}  // namespace
}  // namespace dygslam
