// The dense fallback of issue 16: StaticDepthOdometry on generated frames with exact poses (a
// moving person-sized box fills much of the view), and the System on the real Bonn frames where
// feature tracking alone loses the pose (rgb.txt entries 195-208 of bonn_crowd_part).
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <map>
#include <opencv2/imgproc.hpp>

#include "core/config/settings.h"
#include "core/eval/trajectory_eval.h"
#include "core/io/dataset.h"
#include "core/io/trajectory_io.h"
#include "core/slam/static_depth_odometry.h"
#include "core/system/system.h"
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

TEST(StaticDepthOdometry, VerificationRejectsAWrongPose) {
  const SyntheticOptions o = CrowdedScene();
  SyntheticScene scene(o);
  StaticDepthOdometry odometry(o.camera, StaticDepthOdometryOptions());
  const SyntheticFrame ref = scene.RenderFrame(10);
  const SyntheticFrame cur = scene.RenderFrame(11);
  const DenseView rv = ViewOf(ref, o.sensor, true), cv_ = ViewOf(cur, o.sensor, true);
  const Rigid3d truth = cur.world_from_cam.Inverse() * ref.world_from_cam;
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
    EXPECT_LT(ate.error.rmse, 0.03);
  }
}

// The acceptance figure of issue 16 on the whole sequence: every frame has a pose and the ATE
// over all of them (fallback frames included) stays low. The final trajectory re-anchors each
// fallback stretch on the first feature pose after it (Tracking.fallback_smoothing): it must be
// more accurate than the poses the frames got online.
TEST(SlamFallback, BonnCrowdAllFramesAteWithSmoothedFallbackStretches) {
  DYGSLAM_REQUIRE_DATASET(dir, "bonn_crowd_part");
  const RgbdDataset dataset = RgbdDataset::Open(dir);
  SystemOptions options = BonnFullDeterministicOptions();
  ASSERT_TRUE(options.tracking.fallback_smoothing);  // the default
  std::map<std::string, int> states;
  std::vector<StampedPose> online;
  System system(options);
  for (size_t k = 0; k < dataset.size(); ++k) {
    const cv::Mat rgb = dataset.LoadRgb(k, options.camera.width, options.camera.height);
    const cv::Mat depth = dataset.LoadDepth(k, options.camera.width, options.camera.height);
    const FrameResult r = system.FeedRgbdFrame(rgb, depth, dataset.frame(k).rgb_stamp);
    ++states[ToString(r.state)];
    if (r.world_from_cam) online.push_back({r.stamp, *r.world_from_cam});
  }
  system.Shutdown();
  const std::vector<StampedPose> trajectory = system.Trajectory();
  const auto groundtruth = ReadTumTrajectory(dir + "/groundtruth.txt");
  const AteResult ate = ComputeAte(groundtruth, trajectory);
  const AteResult ate_online = ComputeAte(groundtruth, online);
  std::cout << "bonn_crowd_part (" << dataset.size() << " frames): ok " << states["ok"]
            << ", fallback " << states["fallback"] << ", relocalized " << states["relocalized"]
            << ", lost " << states["lost"] << "; ATE RMSE over all " << trajectory.size()
            << " poses " << ate.error.rmse << " m (online poses " << ate_online.error.rmse
            << " m)\n";
  const int with_pose = states["ok"] + states["fallback"] + states["relocalized"];
  // The promise: every frame has a pose (measured 360 of 360, deterministic: spread 0).
  EXPECT_EQ(with_pose, static_cast<int>(dataset.size()));
  EXPECT_EQ(trajectory.size(), static_cast<size_t>(with_pose));
  EXPECT_GT(states["fallback"], 10);  // the two crowded stretches (~196-208, ~324-331)
  // Measured (deterministic, spread 0 run to run): 0.0133 m smoothed, 0.0155 m online. Limit:
  // the figure + 3 x the spread of this ATE under neutral changes (+-0.0007 m), below the
  // method's acceptance of 0.020 m; the smoothing must not make the trajectory worse.
  EXPECT_LT(ate.error.rmse, 0.0154);
  EXPECT_LE(ate.error.rmse, ate_online.error.rmse);
}

// The crowd passing close at entries 320-334: with Tracking.keyframe_weak_inliers (opt-in) frames
// held by few inliers while people are in view make no keyframe, and the dense fallback holds
// them. Measured (deterministic, spread 0 run to run): RMSE over these entries 0.0282 m with the
// rule at 150, whole run 0.0131 m. Without the rule (the default) the same run measures 0.0229 m
// over these entries and 0.0133 m whole: the rule no longer improves this stretch.
TEST(SlamFallback, BonnCrowdWeaklyHeldFramesMakeNoKeyframes) {
  DYGSLAM_REQUIRE_DATASET(dir, "bonn_crowd_part");
  const RgbdDataset dataset = RgbdDataset::Open(dir);
  SystemOptions options = BonnFullDeterministicOptions();
  options.tracking.keyframe_weak_inliers = 150;
  System system(options);
  int weak_keyframes = 0, with_pose = 0;
  for (size_t k = 0; k < dataset.size(); ++k) {
    const cv::Mat rgb = dataset.LoadRgb(k, options.camera.width, options.camera.height);
    const cv::Mat depth = dataset.LoadDepth(k, options.camera.width, options.camera.height);
    const FrameResult r = system.FeedRgbdFrame(rgb, depth, dataset.frame(k).rgb_stamp);
    with_pose += HasPose(r.state);
    // A keyframe from a frame held by fewer inliers only without a person in view (the rule's
    // second condition); here every such frame has people.
    if (k > 0 && r.is_keyframe && r.num_tracked < 150 && r.num_dynamic > 100) ++weak_keyframes;
  }
  system.Shutdown();
  const auto groundtruth = ReadTumTrajectory(dir + "/groundtruth.txt");
  const AteResult ate = ComputeAte(groundtruth, system.Trajectory());
  const Timestamp stretch_begin = dataset.frame(320).rgb_stamp;
  const Timestamp stretch_end = dataset.frame(334).rgb_stamp;
  double sum_sq = 0;
  int in_stretch = 0;
  for (size_t i = 0; i < ate.est_stamps.size(); ++i) {
    if (SecondsBetween(stretch_begin, ate.est_stamps[i]) < -0.001 ||
        SecondsBetween(ate.est_stamps[i], stretch_end) < -0.001)
      continue;
    sum_sq += ate.errors[i] * ate.errors[i];
    ++in_stretch;
  }
  ASSERT_EQ(in_stretch, 15);
  const double stretch_rmse = std::sqrt(sum_sq / in_stretch);
  std::cout << "weak-frame rule: " << weak_keyframes << " weak keyframes, entries 320-334 RMSE "
            << stretch_rmse << " m, whole run " << ate.error.rmse << " m\n";
  EXPECT_EQ(with_pose, static_cast<int>(dataset.size()));
  EXPECT_EQ(weak_keyframes, 0);
  // Limits: the measured figure + 3 x the spread of the whole-run ATE under neutral changes
  // (+-0.0007 m): 0.0131 + 0.0021 m. The 15-frame stretch moves more than the whole run; its
  // spread is not measured: 10 % (0.0028 m) above its figure.
  EXPECT_LT(stretch_rmse, 0.031);
  EXPECT_LT(ate.error.rmse, 0.0152);
}

}  // namespace
}  // namespace dygslam
