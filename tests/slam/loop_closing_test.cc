// Loop closing end to end on a generated loop path (core/synth): a path that never comes back
// must produce no loop (place recognition sees many similar views along the way; the
// consistency and geometric checks must reject them all); a path that comes back must close the
// loop, re-send the corrected keyframes to the map consumers and keep the per-frame poses apart
// from the corrected trajectory. Figures in BENCHMARKS.md (*Place recognition and loop closing*).
#include <gtest/gtest.h>

#include <map>
#include <set>

#include "core/eval/trajectory_eval.h"
#include "core/synth/synthetic_scene.h"
#include "core/system/system.h"

namespace dygslam {
namespace {

struct LoopRun {
  LoopClosingStats loops;
  double ate = 0, ate_online = 0;  // final trajectory / poses as returned frame by frame
  size_t poses = 0;
  std::vector<StampedPose> online;  // FrameResult poses (what trajectory_online.txt holds)
  std::vector<StampedPose> trajectory;
  int64_t first_loop_frame = -1;      // index of the frame whose processing closed the first loop
  std::set<int64_t> updated_at_loop;  // keyframes sent as pose updates while it was processed
  std::map<int64_t, Rigid3d> last_update;  // latest pose emitted per keyframe stamp (ns)
  std::vector<StampedPose> keyframes;      // KeyframeTrajectory() at the end
};

// A small loop: a 5 x 3 m rounded rectangle (13.4 m) in a 9 x 7 m room at 1.5 m/s, 20 frames/s,
// with depth noise. 0.9 laps never reach the start again; 1.25 laps come back to it and go on.
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
    lap_frames_ = static_cast<int>(perimeter / synth_->loop_speed * synth_->sensor.fps);
    synth_->num_frames = static_cast<int>(1.25 * lap_frames_);
    const SyntheticScene scene(*synth_);
    frames_ = new std::vector<SyntheticFrame>();
    for (int i = 0; i < scene.num_frames(); ++i) frames_->push_back(scene.RenderFrame(i));
  }
  static void TearDownTestSuite() {
    delete frames_;
    delete synth_;
  }
  // fx_scale != 1: the system is given a miscalibrated focal length (the camera's true one times
  // fx_scale), a realistic source of drift: rotations are misjudged, so the heading drifts.
  static LoopRun Run(size_t num_frames, bool loops_enabled = true, double fx_scale = 1.0) {
    SystemOptions options;
    options.camera = synth_->camera;
    options.camera.fx *= fx_scale;
    options.camera.fy *= fx_scale;
    options.sensor = synth_->sensor;
    options.filter_mode = FilterMode::kNone;
    options.deterministic = true;
    options.tracking.max_frames_between_keyframes = 20;
    options.loop_closing.vocabulary =
        std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/vocabulary.dygvoc";
    options.loop_closing.enabled = loops_enabled;
    System system(options);
    LoopRun run;
    system.SetKeyframeCallback([&](const KeyframeData& k) {
      if (!k.removed) run.last_update[k.stamp.nanoseconds()] = k.world_from_cam;
      if (k.pose_update_only && run.first_loop_frame < 0) run.updated_at_loop.insert(k.id);
    });
    std::vector<StampedPose> gt;
    for (size_t i = 0; i < num_frames; ++i) {
      const SyntheticFrame& f = (*frames_)[i];
      if (run.first_loop_frame < 0) run.updated_at_loop.clear();
      const FrameResult r = system.FeedRgbdFrame(f.rgb, f.depth, f.stamp);
      if (r.world_from_cam) run.online.push_back({f.stamp, *r.world_from_cam});
      if (run.first_loop_frame < 0 && system.LoopClosingStatistics().loops_closed > 0)
        run.first_loop_frame = static_cast<int64_t>(i);
      gt.push_back({f.stamp, f.world_from_cam});
    }
    system.Shutdown();
    if (run.first_loop_frame < 0) run.updated_at_loop.clear();
    run.loops = system.LoopClosingStatistics();
    run.trajectory = system.Trajectory();
    run.keyframes = system.KeyframeTrajectory();
    const AteResult ate = ComputeAte(gt, run.trajectory);
    run.ate = ate.error.rmse;
    run.poses = ate.num_pairs;
    run.ate_online = ComputeAte(gt, run.online).error.rmse;
    return run;
  }
  static SyntheticOptions* synth_;
  static std::vector<SyntheticFrame>* frames_;
  static int lap_frames_;
};
int LoopClosingTest::lap_frames_ = 0;
SyntheticOptions* LoopClosingTest::synth_ = nullptr;
std::vector<SyntheticFrame>* LoopClosingTest::frames_ = nullptr;

TEST_F(LoopClosingTest, PathThatNeverComesBackHasNoLoop) {
  const LoopRun open = Run(static_cast<size_t>(0.9 * lap_frames_));
  std::printf("open path: %d loops closed, %d consistent candidates, ATE %.4f m\n",
              open.loops.loops_closed, open.loops.candidates_detected, open.ate);
  EXPECT_EQ(open.loops.loops_closed, 0);
  EXPECT_GT(open.loops.keyframes_checked, 5);  // the loop closer did look at the keyframes
}

TEST_F(LoopClosingTest, ReturnToStartIsClosedAndReported) {
  constexpr double kFxScale = 1.03;
  const LoopRun on = Run(frames_->size(), true, kFxScale);
  const LoopRun off = Run(frames_->size(), false, kFxScale);
  std::printf(
      "1.25 laps, fx 3 %% off: loop closing on: %d loops (%d consistent candidates, %d "
      "rejected), ATE %.4f m over %zu poses; off: ATE %.4f m over %zu poses\n",
      on.loops.loops_closed, on.loops.candidates_detected, on.loops.loops_rejected, on.ate,
      on.poses, off.ate, off.poses);
  for (const LoopVerification& v : on.loops.verifications)
    std::printf(
        "  frame %lld vs %lld: %d / %d inliers, %d matches, correction %.3f m / %.2f deg "
        "(budget %.3f m / %.2f deg over %.2f m): %s\n",
        static_cast<long long>(v.frame_id), static_cast<long long>(v.loop_frame_id), v.inliers,
        v.bow_pairs, v.projected, v.correction_m, v.correction_deg, v.allowed_m, v.allowed_deg,
        v.path_m, v.verdict);
  EXPECT_GE(on.loops.loops_closed, 1);
  // Tracking on this small loop loses the map at the corners and relocalizes against it, so little
  // drift is left for the loop to correct (measured 2026-12-01, fx x1.00 / 1.01 / 1.03: loop
  // corrections 0.013 / 0.022 / 0.020 m, ATE on/off 0.0338/0.0322, 0.0319/0.0292, 0.0840/0.0845 m):
  // closing must not make the trajectory clearly worse. The ">= 3x lower ATE" goal needs a loop
  // with real drift (BENCHMARKS.md).
  EXPECT_LE(on.ate, 1.25 * off.ate);
  // The correction reached the map consumers: keyframes were re-sent as pose updates while the
  // loop's frame was processed, and every keyframe's last emitted pose is its final pose.
  ASSERT_GE(on.first_loop_frame, 0);
  EXPECT_GE(on.updated_at_loop.size(), 5u);
  ASSERT_FALSE(on.keyframes.empty());
  for (const StampedPose& k : on.keyframes) {
    auto sent = on.last_update.find(k.stamp.nanoseconds());
    ASSERT_NE(sent, on.last_update.end());
    EXPECT_LT((sent->second.translation - k.world_from_cam.translation).norm(), 1e-9);
  }
  // trajectory_online keeps what was known at each frame; the final trajectory is the corrected
  // one (loop, global BA and local BA corrections). On this sequence the loop itself corrects
  // < 1 mm (measured 0.4 mm: tracking had relocalized against the start), the global BA after it
  // moves the earlier frames by ~0.1 m, so the two must differ by more than 1 cm.
  const double correction = on.loops.verifications.back().correction_m;
  double moved = 0;
  ASSERT_EQ(on.online.size(), on.trajectory.size());
  for (size_t i = 0; i < on.online.size(); ++i) {
    if (on.online[i].stamp > (*frames_)[on.first_loop_frame].stamp) break;
    ASSERT_EQ(on.online[i].stamp, on.trajectory[i].stamp);
    moved = std::max(moved, (on.online[i].world_from_cam.translation -
                             on.trajectory[i].world_from_cam.translation)
                                .norm());
  }
  std::printf(
      "first loop at frame %lld: %zu keyframes re-sent as pose updates; before it, final "
      "trajectory moved up to %.4f m from the online poses (loop correction %.4f m); ATE "
      "online %.4f m, final %.4f m\n",
      static_cast<long long>(on.first_loop_frame), on.updated_at_loop.size(), moved, correction,
      on.ate_online, on.ate);
  EXPECT_GT(moved, 0.01);
}

}  // namespace
}  // namespace dygslam
