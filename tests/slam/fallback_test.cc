// The dense fallback: StaticDepthOdometry on generated frames with exact poses (a
// moving person-sized box fills much of the view), and the System on the real Bonn frames where
// feature tracking alone loses the pose (rgb.txt entries 195-208 of bonn_crowd_part).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <map>
#include <opencv2/imgproc.hpp>
#include <set>

#include "core/config/settings.h"
#include "core/eval/trajectory_eval.h"
#include "core/io/dataset.h"
#include "core/io/trajectory_io.h"
#include "core/slam/tracking/static_depth_odometry.h"
#include "core/system/system.h"
#include "run/settings_table.h"
#include "run/system_config.h"
#include "tests/support/test_support.h"
#include "tools/synth/synthetic_scene.h"

namespace dygslam {
namespace {

DenseView ViewOf(const SyntheticFrame& f, const RgbdSensorOptions& sensor, bool mask_objects) {
  DenseView v;
  cv::cvtColor(f.rgb, v.gray, cv::COLOR_BGR2GRAY);
  f.depth.convertTo(v.depth, CV_32F, 1.0 / sensor.depth_map_factor);
  if (mask_objects) {
    cv::Mat dynamic;
    cv::dilate(f.dynamic_mask, dynamic, cv::Mat::ones(7, 7, CV_8U));
    cv::bitwise_not(dynamic, v.static_mask);
  }
  return v;
}

struct PoseError {
  double translation_m;
  double rotation_deg;
};
PoseError ErrorOf(const Rigid3d& estimate, const Rigid3d& truth) {
  const Rigid3d d = estimate * truth.Inverse();
  return {d.translation.norm(), RotationAngle(d.rotation) * 180.0 / M_PI};
}

// A scene where a person-sized box walks close in front of the camera.
SyntheticOptions CrowdedScene() {
  SyntheticOptions o;
  o.num_frames = 40;
  o.num_moving_objects = 2;
  o.seed = 3;
  o.object_size = Eigen::Vector3d(0.9, 0.4, 1.9);
  o.depth_noise = true;
  return o;
}

// Two neighbouring frames of the crowded scene (entries 10 and 11) and the true motion between
// them: the pair the verification tests align.
struct CrowdedPair {
  SyntheticOptions options = CrowdedScene();
  SyntheticFrame ref, cur;
  Rigid3d cur_from_ref;
};
CrowdedPair MakeCrowdedPair() {
  CrowdedPair pair;
  SyntheticScene scene(pair.options);
  pair.ref = scene.RenderFrame(10);
  pair.cur = scene.RenderFrame(11);
  pair.cur_from_ref = pair.cur.world_from_cam.Inverse() * pair.ref.world_from_cam;
  return pair;
}

TEST(StaticDepthOdometry, RecoversGeneratedMotionWithPersonMaskedOut) {
  const SyntheticOptions o = CrowdedScene();
  SyntheticScene scene(o);
  StaticDepthOdometry odometry(o.camera, StaticDepthOdometryOptions());
  int verified = 0, frames_with_object = 0;
  double worst_t = 0, worst_r = 0, sum_t = 0, sum_seed_t = 0;
  int pairs = 0;
  for (int k = 1; k + 1 < o.num_frames; k += 3) {
    const SyntheticFrame ref = scene.RenderFrame(k);
    const SyntheticFrame cur = scene.RenderFrame(k + 1);
    const double dynamic_share =
        cv::countNonZero(cur.dynamic_mask) / double(cur.dynamic_mask.total());
    if (dynamic_share > 0.05) ++frames_with_object;
    const Rigid3d truth = cur.world_from_cam.Inverse() * ref.world_from_cam;  // cur_from_ref
    // Seed: the previous step's motion (constant velocity), as the tracker does, made 3 cm and
    // 1.5 degrees wrong (the generated path is so smooth that the plain seed would be exact).
    const Rigid3d seed_error(
        Eigen::AngleAxisd(1.5 * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix(),
        Eigen::Vector3d(0.02, -0.01, 0.02));
    const Rigid3d prev_step =
        seed_error * ref.world_from_cam.Inverse() * scene.RenderFrame(k - 1).world_from_cam;
    const StaticDepthEstimate e =
        odometry.Estimate(ViewOf(ref, o.sensor, true), ViewOf(cur, o.sensor, true), prev_step);
    ASSERT_TRUE(e.converged) << "frame " << k;
    const PoseError err = ErrorOf(e.cur_from_ref, truth);
    worst_t = std::max(worst_t, err.translation_m);
    worst_r = std::max(worst_r, err.rotation_deg);
    sum_t += err.translation_m;
    sum_seed_t += ErrorOf(prev_step, truth).translation_m;
    ++pairs;
    verified += e.verified;
    EXPECT_GE(e.agreement.inlier_fraction(), 0.8) << "frame " << k;
  }
  std::cout << "generated: " << verified << " verified, " << frames_with_object
            << " pairs with a person; error mean " << sum_t / pairs * 1000 << " mm (seed "
            << sum_seed_t / pairs * 1000 << " mm), worst " << worst_t * 1000 << " mm, " << worst_r
            << " deg\n";
  EXPECT_GT(frames_with_object, 0);
  EXPECT_EQ(verified, pairs);
  // Measured: mean 3.3 mm (seed 30 mm), worst 17 mm, 0.31 deg (depth noise 0.0015 z^2).
  EXPECT_LT(worst_t, 0.025);
  EXPECT_LT(worst_r, 0.5);
  // A real estimate, not the motion-model seed.
  EXPECT_LT(sum_t, 0.5 * sum_seed_t);
}

// A person fills 95 % of the view: the static pixels are a strip at the image's edge. The plain
// alignment slides along the directions the strip leaves free; the estimate with the motion prior
// takes those from the prior and the rest from the pixels.
TEST(StaticDepthOdometry, ConstrainedEstimateHoldsANarrowStrip) {
  SyntheticOptions o;
  o.num_frames = 150;
  o.num_moving_objects = 0;
  o.seed = 1;
  o.depth_noise = true;
  o.occluder_coverage = 0.95;
  o.occluder_start_frame = 60;
  SyntheticScene scene(o);
  StaticDepthOdometry odometry(o.camera, StaticDepthOdometryOptions());
  double sum_t = 0, sum_r = 0, sum_seed_t = 0, sum_seed_r = 0, sum_plain_t = 0;
  int pairs = 0, verified = 0;
  for (int k = 72; k < 90; k += 2) {
    const SyntheticFrame ref = scene.RenderFrame(k);
    const SyntheticFrame cur = scene.RenderFrame(k + 1);
    const Rigid3d truth = cur.world_from_cam.Inverse() * ref.world_from_cam;
    const Rigid3d prev_step =
        ref.world_from_cam.Inverse() * scene.RenderFrame(k - 1).world_from_cam;
    const StaticDepthEstimate e = odometry.EstimateWithPrior(
        ViewOf(ref, o.sensor, true), ViewOf(cur, o.sensor, true), prev_step);
    const PoseError err = ErrorOf(e.cur_from_ref, truth);
    const PoseError seed_err = ErrorOf(prev_step, truth);
    const StaticDepthEstimate plain =
        odometry.Estimate(ViewOf(ref, o.sensor, true), ViewOf(cur, o.sensor, true), prev_step);
    sum_plain_t += ErrorOf(plain.cur_from_ref, truth).translation_m;
    std::cout << k << ": " << err.translation_m * 1000 << " mm " << err.rotation_deg
              << " deg (seed " << seed_err.translation_m * 1000 << " mm " << seed_err.rotation_deg
              << " deg) " << e.agreement.inliers << " inliers\n";
    sum_t += err.translation_m;
    sum_r += err.rotation_deg;
    sum_seed_t += seed_err.translation_m;
    sum_seed_r += seed_err.rotation_deg;
    verified += e.verified;
    ++pairs;
  }
  std::cout << "strip: mean " << sum_t / pairs * 1000 << " mm, " << sum_r / pairs
            << " deg; plain alignment " << sum_plain_t / pairs * 1000 << " mm\n";
  EXPECT_EQ(verified, pairs);
  EXPECT_LT(sum_t / pairs, 0.003);
  EXPECT_LT(sum_t, 0.5 * sum_plain_t);
}

TEST(StaticDepthOdometry, VerificationRejectsAWrongPose) {
  const CrowdedPair pair = MakeCrowdedPair();
  const SyntheticOptions& o = pair.options;
  StaticDepthOdometry odometry(o.camera, StaticDepthOdometryOptions());
  const DenseView rv = ViewOf(pair.ref, o.sensor, true), cv_ = ViewOf(pair.cur, o.sensor, true);
  const Rigid3d& truth = pair.cur_from_ref;
  const DepthAgreement good = odometry.Agreement(rv, cv_, truth);
  // 8 cm forward and 4 degrees of yaw off.
  const Rigid3d off(
      Eigen::AngleAxisd(4.0 * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix(),
      Eigen::Vector3d(0.0, 0.0, 0.08));
  const DepthAgreement bad = odometry.Agreement(rv, cv_, off * truth);
  std::cout << "agreement: true pose " << good.inlier_fraction() << " (" << good.inliers
            << "), wrong pose " << bad.inlier_fraction() << " (" << bad.inliers << ")\n";
  EXPECT_GE(good.inlier_fraction(), 0.9);
  EXPECT_LT(bad.inlier_fraction(), odometry.options().min_inlier_fraction);
}

// A static mask made on first use (what the System gives every frame, since most frames are
// never aligned) is made once and counts as the same mask given up front: same agreement.
TEST(StaticDepthOdometry, AStaticMaskMadeOnFirstUseIsTheMaskGivenUpFront) {
  const CrowdedPair pair = MakeCrowdedPair();
  const SyntheticOptions& o = pair.options;
  StaticDepthOdometry odometry(o.camera, StaticDepthOdometryOptions());
  const SyntheticFrame& cur = pair.cur;
  const DenseView rv = ViewOf(pair.ref, o.sensor, true), eager = ViewOf(cur, o.sensor, true);
  DenseView lazy = ViewOf(cur, o.sensor, false);
  int made = 0;
  lazy.make_static_mask = [&made, mask = eager.static_mask] {
    ++made;
    return mask;
  };
  EXPECT_EQ(made, 0);
  const Rigid3d& truth = pair.cur_from_ref;
  const DepthAgreement a = odometry.Agreement(rv, eager, truth);
  const DepthAgreement b = odometry.Agreement(rv, lazy, truth);
  EXPECT_EQ(made, 1);
  EXPECT_EQ(a.samples, b.samples);
  EXPECT_EQ(a.inliers, b.inliers);
  EXPECT_LT(b.samples, odometry.Agreement(rv, ViewOf(cur, o.sensor, false), truth).samples)
      << "the mask left nothing out";
  odometry.Agreement(lazy, rv, truth);
  EXPECT_EQ(made, 1);
}

// config/bonn.yaml with the full filter in deterministic mode: the real-data runs below.
SystemOptions BonnFullDeterministicOptions() {
  SystemOptions options = SystemOptionsFromSettings(
      LoadSettings(std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/bonn.yaml"));
  options.filter.mode = FilterMode::kFull;
  options.deterministic = true;
  return options;
}

TEST(StaticDepthOdometry, RejectsViewsOfTheWrongSize) {
  StaticDepthOdometry odometry(DefaultSyntheticCamera(), StaticDepthOdometryOptions());
  DenseView small;
  small.gray = cv::Mat::zeros(10, 10, CV_8UC1);
  small.depth = cv::Mat::zeros(10, 10, CV_32FC1);
  EXPECT_THROW(odometry.Estimate(small, small, Rigid3d()), InputError);
  StaticDepthOdometryOptions bad;
  bad.min_inlier_fraction = 0;
  EXPECT_THROW(StaticDepthOdometry(DefaultSyntheticCamera(), bad), InvalidOptions);
}

// Real data: the frames where a person fills the view get a verified dense pose instead of none,
// none of them becomes a keyframe, and tracking returns to features afterwards.
TEST(SlamFallback, BonnCrowdFramesWherePersonFillsTheViewGetAPose) {
  DYGSLAM_REQUIRE_DATASET(dir, "bonn_crowd_part");
  const RgbdDataset dataset = RgbdDataset::Open(dir);
  SystemOptions options = BonnFullDeterministicOptions();
  std::map<std::string, int> states;
  int fallback_keyframes = 0, ok_after_fallback = 0;
  bool seen_fallback = false;
  {
    System system(options);
    constexpr size_t kFirst = 170, kLast = 225;
    for (size_t k = kFirst; k < kLast; ++k) {
      const auto index = dataset.FrameForRgbEntry(k);
      ASSERT_TRUE(index);
      const cv::Mat rgb = dataset.LoadRgb(*index, options.camera.width, options.camera.height);
      const cv::Mat depth = dataset.LoadDepth(*index, options.camera.width, options.camera.height);
      const FrameResult r = system.FeedRgbdFrame(rgb, depth, dataset.frame(*index).rgb_stamp);
      ++states[ToString(r.state)];
      EXPECT_EQ(r.world_from_cam.has_value(), HasPose(r.state));
      if (r.state == TrackingState::kFallback) {
        seen_fallback = true;
        fallback_keyframes += r.is_keyframe;
      } else if (seen_fallback && r.state == TrackingState::kOk) {
        ++ok_after_fallback;
      }
    }
    system.Shutdown();
    const std::vector<StampedPose> trajectory = system.Trajectory();
    const AteResult ate = ComputeAte(ReadTumTrajectory(dir + "/groundtruth.txt"), trajectory);
    std::cout << "entries 170-224: ok " << states["ok"] << ", fallback " << states["fallback"]
              << ", relocalized " << states["relocalized"] << ", lost " << states["lost"]
              << "; ATE RMSE " << ate.error.rmse << " m over " << ate.num_pairs << " poses\n";
    EXPECT_GE(states["fallback"], 10);  // entries 195-208 were lost before the fallback
    EXPECT_LE(states["lost"], 1);
    EXPECT_EQ(fallback_keyframes, 0);
    EXPECT_GT(ok_after_fallback, 5);
    // Measured 0.0317 m with the shipped defaults (0.0283 m with the former dataset preset's
    // detector on every frame and local mapping waited for): a 55-frame excerpt that starts in
    // the crowd; 0.035 m leaves 10 %.
    EXPECT_LT(ate.error.rmse, 0.035);
  }
}

// Every frame of the whole sequence has a pose and the ATE over all of them (fallback frames
// included) stays low. The final trajectory re-anchors each fallback stretch on the first feature
// pose after it (Tracking.fallback_smoothing): on the fallback frames it must be more accurate
// than the same run without it. One run is a single sample of a chaotic system (starting one
// frame later moves the whole-run ATE by up to 0.002 m), so the comparison is the median over
// three start frames.
TEST(SlamFallback, BonnCrowdAllFramesAteWithSmoothedFallbackStretches) {
  DYGSLAM_REQUIRE_DATASET(dir, "bonn_crowd_part");
  const RgbdDataset dataset = RgbdDataset::Open(dir);
  const auto groundtruth = ReadTumTrajectory(dir + "/groundtruth.txt");
  struct Outcome {
    std::map<std::string, int> states;
    std::vector<StampedPose> trajectory;
    AteResult ate, ate_online;
    double fallback_rmse =
        0;  // over the frames tracked by the fallback, in the whole-run alignment
    // Feature frames right after a fallback frame held by fewer inliers than
    // Tracking.fallback_smoothing_weak_inliers, and how many of them became keyframes.
    int weak_returns = 0, weak_return_keyframes = 0;
  };
  auto run = [&](bool smoothing, size_t first) {
    SystemOptions options = BonnFullDeterministicOptions();
    options.tracking.fallback_smoothing = smoothing;
    Outcome o;
    std::vector<StampedPose> online;
    std::set<Timestamp> fallback;
    System system(options);
    TrackingState previous = TrackingState::kNotInitialized;
    for (size_t k = first; k < dataset.size(); ++k) {
      const cv::Mat rgb = dataset.LoadRgb(k, options.camera.width, options.camera.height);
      const cv::Mat depth = dataset.LoadDepth(k, options.camera.width, options.camera.height);
      const FrameResult r = system.FeedRgbdFrame(rgb, depth, dataset.frame(k).rgb_stamp);
      ++o.states[ToString(r.state)];
      if (previous == TrackingState::kFallback && r.state == TrackingState::kOk &&
          r.num_tracked < options.tracking.fallback_smoothing_weak_inliers) {
        ++o.weak_returns;
        o.weak_return_keyframes += r.is_keyframe;
      }
      previous = r.state;
      if (r.state == TrackingState::kFallback) fallback.insert(r.stamp);
      if (r.world_from_cam) online.push_back({r.stamp, *r.world_from_cam});
    }
    system.Shutdown();
    o.trajectory = system.Trajectory();
    o.ate = ComputeAte(groundtruth, o.trajectory);
    o.ate_online = ComputeAte(groundtruth, online);
    double sum = 0;
    int count = 0;
    for (size_t i = 0; i < o.ate.est_stamps.size(); ++i) {
      if (fallback.count(o.ate.est_stamps[i]) == 0) continue;
      sum += o.ate.errors[i] * o.ate.errors[i];
      ++count;
    }
    o.fallback_rmse = count > 0 ? std::sqrt(sum / count) : 0;
    return o;
  };
  ASSERT_TRUE(BonnFullDeterministicOptions().tracking.fallback_smoothing);  // the default
  std::vector<double> smoothed_fallback, plain_fallback;
  int weak_returns = 0;
  for (const size_t first : {size_t{0}, size_t{1}, size_t{2}}) {
    Outcome smoothed = run(true, first);
    Outcome plain = run(false, first);
    smoothed_fallback.push_back(smoothed.fallback_rmse);
    plain_fallback.push_back(plain.fallback_rmse);
    // The first feature pose after a crowd can be centimetres off (entry 206 from entry 0: 86
    // inliers, 5 cm): such a frame makes no keyframe that later frames and points would hang on.
    weak_returns += smoothed.weak_returns + plain.weak_returns;
    EXPECT_EQ(smoothed.weak_return_keyframes, 0) << "from entry " << first;
    EXPECT_EQ(plain.weak_return_keyframes, 0) << "from entry " << first;
    std::cout << "bonn_crowd_part from entry " << first << " (" << dataset.size() - first
              << " frames): ok " << smoothed.states["ok"] << ", fallback "
              << smoothed.states["fallback"] << ", relocalized " << smoothed.states["relocalized"]
              << ", lost " << smoothed.states["lost"] << "; ATE RMSE over all "
              << smoothed.trajectory.size() << " poses " << smoothed.ate.error.rmse
              << " m (online poses " << smoothed.ate_online.error.rmse << " m); fallback frames "
              << smoothed.fallback_rmse << " m; without the smoothing " << plain.ate.error.rmse
              << " m, fallback frames " << plain.fallback_rmse << " m\n";
    if (first != 0) continue;
    const int with_pose =
        smoothed.states["ok"] + smoothed.states["fallback"] + smoothed.states["relocalized"];
    EXPECT_EQ(with_pose, static_cast<int>(dataset.size()));
    EXPECT_EQ(smoothed.trajectory.size(), static_cast<size_t>(with_pose));
    EXPECT_GT(smoothed.states["fallback"], 10);  // the two crowded stretches (~196-208, ~324-331)
    // Measured with the shipped defaults (deterministic, equal to threaded runs; spread 0 run
    // to run): 0.0142 m final, 0.0129 m online. Limit: 0.0146 m (the figure before the
    // planar-to-line residual) + 3 x the spread of this ATE under neutral changes (+-0.0007 m).
    EXPECT_LT(smoothed.ate.error.rmse, 0.0167);
  }
  EXPECT_GE(weak_returns, 1);  // the rule above was exercised
  // Measured: fallback frames 0.0299 / 0.0112 / 0.0166 m smoothed against 0.0114 / 0.0240 /
  // 0.0278 m without (start entries 0 / 1 / 2).
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  EXPECT_LT(median(smoothed_fallback), median(plain_fallback));
}

}  // namespace
}  // namespace dygslam
