// Issue 22: the local-mapping schedule under real threading. With Tracking.handoff_wait_ms the
// tracker waits after each keyframe until local mapping is done with it, so every keyframe is
// handed to an idle local mapper and must get its whole local BA: none may be stopped early.
// (Before the fix in LocalMapper::InsertKeyFrame the abort flag was raised after the push, and
// the worker, having already taken the keyframe and cleared the flag, then stopped that
// keyframe's own BA after its first iteration: 30-36 of ~55 keyframes on bonn_crowd_part.)
#include <gtest/gtest.h>

#include <vector>

#include "core/system/system.h"
#include "tools/synth/synthetic_scene.h"

namespace dygslam {
namespace {

TEST(LocalMappingSchedule, KeyframesHandedToAnIdleMapperGetTheirWholeLocalBa) {
  SyntheticOptions synth;
  synth.num_frames = 90;
  synth.num_moving_objects = 0;
  synth.supersampling = 1;
  synth.seed = 3;
  synth.depth_noise = true;
  synth.path_amplitude = 0.4;
  synth.yaw_amplitude_deg = 15;
  const SyntheticScene scene(synth);
  SystemOptions options;
  options.camera = synth.camera;
  options.sensor = synth.sensor;
  options.filter.mode = FilterMode::kNone;
  options.tracking.handoff_wait_ms = 10000;  // real threading, but one keyframe at a time
  System system(options);
  for (int i = 0; i < scene.num_frames(); ++i) {
    const SyntheticFrame f = scene.RenderFrame(i);
    system.FeedRgbdFrame(f.rgb, f.depth, f.stamp);
  }
  system.Shutdown();
  const LocalMappingStats stats = system.LocalMappingStatistics();
  ASSERT_GE(stats.keyframes_processed, 4) << "too few keyframes to test the schedule";
  ASSERT_EQ(stats.queue_at_insert.size(), static_cast<size_t>(stats.keyframes_processed));
  ASSERT_EQ(stats.lag_ms.size(), static_cast<size_t>(stats.keyframes_processed));
  for (size_t k = 0; k < stats.queue_at_insert.size(); ++k)
    EXPECT_EQ(stats.queue_at_insert[k], 0) << "keyframe " << k << " queued behind another";
  EXPECT_EQ(stats.ba_interrupted, 0) << "of " << stats.keyframes_processed << " keyframes";
  // Only the first two keyframes go without local BA (it needs three keyframes in the map).
  EXPECT_LE(stats.keyframes_without_ba, 2);
  EXPECT_EQ(system.Trajectory().size(), static_cast<size_t>(scene.num_frames()));
}

}  // namespace
}  // namespace dygslam
