// Loop closing end to end on generated loops (core/synth loop path): the return to the start is
// detected and closed, the closed trajectory is no worse than with loop closing off, and a path
// that never comes back produces no loop.
#include <gtest/gtest.h>

#include "core/eval/trajectory_eval.h"
#include "core/synth/synthetic_scene.h"
#include "core/system/system.h"

namespace dygslam {
namespace {

struct LoopRun {
  LoopClosingStats loops;
  double ate = 0;
  size_t poses = 0;
};

// A small loop: a 5 x 3 m rounded rectangle (13.4 m) in a 9 x 7 m room at 1.2 m/s, 15 frames/s,
// rendered at 320 x 240 so the test takes seconds. `laps` < 1: the path never comes back.
LoopRun RunLoop(double laps, bool loop_closing) {
  SyntheticOptions synth;
  synth.seed = 17;
  synth.num_moving_objects = 0;
  synth.supersampling = 1;
  synth.room_size = {9.0, 7.0, 3.0};
  synth.loop_semi_axes = {2.5, 1.5};
  synth.loop_speed = 1.2;
  synth.sensor.fps = 15;
  synth.camera.width = 320;
  synth.camera.height = 240;
  synth.camera.fx = synth.camera.fy = 262.5;
  synth.camera.cx = 159.5;
  synth.camera.cy = 119.5;
  synth.depth_noise = true;
  const double perimeter = 4 * (2.5 + 1.5) - 8 * 1.5 + 2 * M_PI * 1.5;  // rounded rectangle: 13.4 m
  synth.num_frames = static_cast<int>(laps * perimeter / synth.loop_speed * synth.sensor.fps);
  const SyntheticScene scene(synth);
  SystemOptions options;
  options.camera = synth.camera;
  options.sensor = synth.sensor;
  options.orb.num_features = 600;
  options.filter_mode = FilterMode::kNone;
  options.deterministic = true;
  options.tracking.max_frames_between_keyframes = 15;
  options.loop_closing.vocabulary =
      std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/vocabulary.dygvoc";
  options.loop_closing.enabled = loop_closing;
  System system(options);
  std::vector<StampedPose> gt;
  for (int i = 0; i < scene.num_frames(); ++i) {
    const SyntheticFrame f = scene.RenderFrame(i);
    system.FeedRgbdFrame(f.rgb, f.depth, f.stamp);
    gt.push_back({f.stamp, f.world_from_cam});
  }
  system.Shutdown();
  LoopRun run;
  run.loops = system.LoopClosingStatistics();
  const AteResult ate = ComputeAte(gt, system.Trajectory());
  run.ate = ate.error.rmse;
  run.poses = ate.num_pairs;
  return run;
}

TEST(LoopClosing, GeneratedLoopIsClosedAndNoFalseLoopWithoutReturn) {
  const LoopRun on = RunLoop(1.25, true);
  const LoopRun off = RunLoop(1.25, false);
  std::printf(
      "generated loop: %d loops closed, ATE %.4f m with loop closing, %.4f m without (%zu poses)\n",
      on.loops.loops_closed, on.ate, off.ate, on.poses);
  EXPECT_GE(on.loops.loops_closed, 1);
  EXPECT_EQ(off.loops.loops_closed, 0);
  EXPECT_LE(on.ate, off.ate);
  const LoopRun open = RunLoop(0.75, true);
  std::printf("open path: %d loops closed, %d consistent candidates, ATE %.4f m\n",
              open.loops.loops_closed, open.loops.candidates_detected, open.ate);
  EXPECT_EQ(open.loops.loops_closed, 0);
}

}  // namespace
}  // namespace dygslam
