// Loop closing end to end on a generated loop path (core/synth): a path that never comes back
// must produce no loop (place recognition sees many similar views along the way; the
// consistency and geometric checks must reject them all). The closed-loop figures are in
// BENCHMARKS.md (*Loop closing*).
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

// A small loop: a 5 x 3 m rounded rectangle (13.4 m) in a 9 x 7 m room at 1.5 m/s, 20 frames/s,
// with depth noise; 0.9 laps: it never reaches the start again.
class LoopClosingTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    synth_ = new SyntheticOptions();
    synth_->seed = 17;
    synth_->num_moving_objects = 0;
    synth_->supersampling = 1;
    synth_->room_size = {9.0, 7.0, 3.0};
    synth_->loop_semi_axes = {2.5, 1.5};
    synth_->loop_speed = 1.5;
    synth_->sensor.fps = 20;
    synth_->depth_noise = true;
    const double perimeter = 4 * (2.5 + 1.5) - 8 * 1.5 + 2 * M_PI * 1.5;  // 13.4 m
    synth_->num_frames =
        static_cast<int>(0.9 * perimeter / synth_->loop_speed * synth_->sensor.fps);
    const SyntheticScene scene(*synth_);
    frames_ = new std::vector<SyntheticFrame>();
    for (int i = 0; i < scene.num_frames(); ++i) frames_->push_back(scene.RenderFrame(i));
  }
  static void TearDownTestSuite() {
    delete frames_;
    delete synth_;
  }
  static LoopRun Run(size_t num_frames) {
    SystemOptions options;
    options.camera = synth_->camera;
    options.sensor = synth_->sensor;
    options.filter_mode = FilterMode::kNone;
    options.deterministic = true;
    options.tracking.max_frames_between_keyframes = 20;
    options.loop_closing.vocabulary =
        std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/vocabulary.dygvoc";
    options.loop_closing.enabled = true;
    System system(options);
    std::vector<StampedPose> gt;
    for (size_t i = 0; i < num_frames; ++i) {
      const SyntheticFrame& f = (*frames_)[i];
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
  static SyntheticOptions* synth_;
  static std::vector<SyntheticFrame>* frames_;
};
SyntheticOptions* LoopClosingTest::synth_ = nullptr;
std::vector<SyntheticFrame>* LoopClosingTest::frames_ = nullptr;

TEST_F(LoopClosingTest, PathThatNeverComesBackHasNoLoop) {
  const LoopRun open = Run(frames_->size());
  std::printf("open path: %d loops closed, %d consistent candidates, ATE %.4f m\n",
              open.loops.loops_closed, open.loops.candidates_detected, open.ate);
  EXPECT_EQ(open.loops.loops_closed, 0);
  EXPECT_GT(open.loops.keyframes_checked, 5);  // the loop closer did look at the keyframes
}

}  // namespace
}  // namespace dygslam
