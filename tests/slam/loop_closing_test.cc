// Loop closing end to end on a generated loop path (tools/synth): a path that never comes back
// must produce no loop (place recognition sees many similar views along the way; the
// consistency and geometric checks must reject them all); a path that comes back must close the
// loop, correct the drift, re-send the corrected keyframes to the map consumers and keep the
// per-frame poses apart from the corrected trajectory; and tracking must go on while the global
// bundle adjustment after the loop runs (threaded). Figures in BENCHMARKS.md (*Place recognition
// and loop closing*).
#include <gtest/gtest.h>

#include <chrono>
#include <map>
#include <set>
#include <string>
#include <thread>

#include "core/eval/trajectory_eval.h"
#include "core/system/system.h"
#include "tools/synth/synthetic_scene.h"

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

double SteadySeconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// A small inward loop (SyntheticOptions::loop_inward): a 6 x 4.4 m rounded rectangle with 1.2 m
// corner radius (18.7 m) round a floor-to-ceiling pillar, the camera looking at the pillar from
// 1.2 m, at 1.4 m/s and 20 frames/s, with depth and colour noise. Tracking holds all the way round
// (the outward loops of the earlier rounds had walls beyond ThDepth at the corners and lost the
// map), so the drift is still there when the camera comes back. 0.9 laps never reach the start
// again; 1.3 laps come back to it and go on.
class LoopClosingTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    synth_ = new SyntheticOptions();
    synth_->seed = 17;
    synth_->num_moving_objects = 0;
    synth_->supersampling = 1;
    synth_->room_size = {8.5, 7.0, 3.0};
    synth_->loop_semi_axes = {3.0, 2.2};
    synth_->loop_corner_radius = 1.2;
    synth_->loop_inward = true;
    synth_->loop_speed = 1.4;
    synth_->texels_per_metre = 200;
    synth_->sensor.fps = 20;
    synth_->depth_noise = true;
    synth_->rgb_noise_sigma = 2.0;
    const double a = 3.0, b = 2.2, r = 1.2;
    const double perimeter = 4 * (a + b) - 8 * r + 2 * M_PI * r;  // 18.7 m
    lap_frames_ = static_cast<int>(perimeter / synth_->loop_speed * synth_->sensor.fps);
    synth_->num_frames = static_cast<int>(1.3 * lap_frames_);
    frames_ = new std::vector<SyntheticFrame>();
  }
  static void TearDownTestSuite() {
    delete frames_;
    delete synth_;
  }
  // Renders the first n frames (once per test process, on two threads).
  static void Render(size_t n) {
    if (frames_->size() >= n) return;
    const SyntheticScene scene(*synth_);
    const size_t first = frames_->size();
    frames_->resize(n);
    auto work = [&](size_t parity) {
      for (size_t i = first + parity; i < n; i += 2)
        (*frames_)[i] = scene.RenderFrame(static_cast<int>(i));
    };
    std::thread other(work, 1);
    work(0);
    other.join();
  }
  static SystemOptions Options(bool loops_enabled, bool deterministic) {
    SystemOptions options;
    options.camera = synth_->camera;
    options.sensor = synth_->sensor;
    options.filter.mode = FilterMode::kNone;
    options.deterministic = deterministic;
    options.tracking.max_frames_between_keyframes = 20;
    options.loop_closing.vocabulary =
        std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/vocabulary.dygvoc";
    options.loop_closing.enabled = loops_enabled;
    return options;
  }
  static LoopRun Run(size_t num_frames, bool loops_enabled = true) {
    Render(num_frames);
    System system(Options(loops_enabled, true));
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
  std::printf("open path: %d loops closed, %d consistent candidates, ATE %.4f m over %zu poses\n",
              open.loops.loops_closed, open.loops.candidates_detected, open.ate, open.poses);
  EXPECT_EQ(open.loops.loops_closed, 0);
  EXPECT_GT(open.loops.keyframes_checked, 20);  // the loop closer did look at the keyframes
}

TEST_F(LoopClosingTest, ReturnToStartIsClosedAndCorrectsTheDrift) {
  const size_t n = static_cast<size_t>(synth_->num_frames);
  const LoopRun on = Run(n, true);
  const LoopRun off = Run(n, false);
  std::printf(
      "1.3 laps: loop closing on: %d loops (%d consistent candidates, %d rejected), ATE %.4f m "
      "over %zu poses; off: ATE %.4f m over %zu poses (%.2fx)\n",
      on.loops.loops_closed, on.loops.candidates_detected, on.loops.loops_rejected, on.ate,
      on.poses, off.ate, off.poses, off.ate / on.ate);
  for (const LoopVerification& v : on.loops.verifications)
    if (v.frame_id + 40 >= static_cast<int64_t>(lap_frames_))  // the return
      std::printf(
          "  frame %lld vs %lld: %d / %d inliers, %d matches, correction %.3f m / %.2f deg "
          "(budget %.3f m / %.2f deg over %.2f m): %s\n",
          static_cast<long long>(v.frame_id), static_cast<long long>(v.loop_frame_id), v.inliers,
          v.bow_pairs, v.projected, v.correction_m, v.correction_deg, v.allowed_m, v.allowed_deg,
          v.path_m, v.verdict);
  // Tracking holds on the whole lap, in both runs.
  EXPECT_EQ(on.poses, n);
  EXPECT_EQ(off.poses, n);
  EXPECT_GE(on.loops.loops_closed, 1);
  // The drift of the lap is corrected: the goal is an ATE >= 3x lower with loop closing.
  // Measured 2026-12-02 (deterministic): on 0.0388 m, off 0.1995 m (5.1x); the loop moved the
  // camera 0.50 m / 9.4 deg at frame 315 (lap: 267 frames).
  EXPECT_LE(3.0 * on.ate, off.ate);
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
  // one: frames before the loop moved by about the loop correction.
  double correction = 0;  // of the accepted loop (rejections are recorded too)
  for (const LoopVerification& v : on.loops.verifications)
    if (std::string(v.verdict) == "accepted") correction = v.correction_m;
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
  EXPECT_GT(moved, 0.5 * correction);
  EXPECT_LT(on.ate, on.ate_online);
}

// Threaded (real threads, as a live run): the global BA after the loop runs on its own thread
// and tracking goes on meanwhile. Frames are fed as fast as they are processed; a frame whose
// whole processing (FeedRgbdFrame) lies inside a global BA window was tracked while the BA ran.
// If tracking waited for the BA (a lock held by it), no frame could both start and end inside.
TEST_F(LoopClosingTest, TrackingGoesOnWhileTheGlobalBundleAdjustmentRuns) {
  Render(static_cast<size_t>(synth_->num_frames));
  System system(Options(true, false));
  struct Timed {
    double start, end;
  };
  std::vector<Timed> times;
  size_t fed = 0;
  for (; fed < frames_->size(); ++fed) {
    const SyntheticFrame& f = (*frames_)[fed];
    const double start = SteadySeconds();
    system.FeedRgbdFrame(f.rgb, f.depth, f.stamp);
    times.push_back({start, SteadySeconds()});
    const LoopClosingStats s = system.LoopClosingStatistics();
    // Done once a global BA has ended and a few frames followed it.
    if (!s.global_ba_windows_s.empty() && !s.global_ba_running &&
        times.back().start > s.global_ba_windows_s.back().second)
      break;
  }
  system.Shutdown();
  const LoopClosingStats s = system.LoopClosingStatistics();
  ASSERT_GE(s.loops_closed, 1) << "no loop closed in " << fed << " frames (threaded)";
  ASSERT_FALSE(s.global_ba_windows_s.empty());
  size_t inside = 0;
  double longest_ms = 0, ba_ms = 0;
  for (const auto& [ba_start, ba_end] : s.global_ba_windows_s) {
    ba_ms = std::max(ba_ms, (ba_end - ba_start) * 1e3);
    for (const Timed& t : times) {
      if (t.start >= ba_start && t.end <= ba_end) ++inside;
      if (t.start < ba_end && t.end > ba_start)
        longest_ms = std::max(longest_ms, (t.end - t.start) * 1e3);
    }
  }
  std::printf(
      "threaded: %d loops closed, %zu global BAs (longest %.0f ms), %zu frames tracked entirely "
      "inside one, longest frame overlapping one %.0f ms\n",
      s.loops_closed, s.global_ba_windows_s.size(), ba_ms, inside, longest_ms);
  EXPECT_GE(inside, 3u);
}

}  // namespace
}  // namespace dygslam
