#include "core/eval/trajectory_eval.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/base/error.h"

namespace dygslam {
namespace {

// A smooth synthetic camera path: helix with changing orientation, `n` poses every `dt_ns`.
std::vector<StampedPose> MakePath(int n, int64_t dt_ns = 40'000'000) {
  std::vector<StampedPose> poses;
  for (int i = 0; i < n; ++i) {
    const double t = i * dt_ns * 1e-9;
    StampedPose p;
    p.stamp = Timestamp::FromNanoseconds(1'000'000'000'000'000'000LL + i * dt_ns);
    p.world_from_cam.translation =
        Eigen::Vector3d(2 * std::cos(0.3 * t), 1.5 * std::sin(0.3 * t), 0.1 * t);
    p.world_from_cam.rotation = Eigen::AngleAxisd(0.3 * t, Eigen::Vector3d::UnitZ()) *
                                Eigen::AngleAxisd(0.2 * std::sin(t), Eigen::Vector3d::UnitX());
    poses.push_back(p);
  }
  return poses;
}

Rigid3d SomeTransform() {
  return Rigid3d(
      Eigen::Quaterniond(Eigen::AngleAxisd(1.1, Eigen::Vector3d(0.3, -0.5, 0.8).normalized())),
      Eigen::Vector3d(3.0, -7.5, 1.25));
}

TEST(ErrorStatistics, MatchesHandComputedValues) {
  const ErrorStatistics s = ComputeErrorStatistics({4, 1, 3, 2});
  EXPECT_DOUBLE_EQ(s.rmse, std::sqrt(7.5));
  EXPECT_DOUBLE_EQ(s.mean, 2.5);
  EXPECT_DOUBLE_EQ(s.median, 2.5);
  EXPECT_DOUBLE_EQ(s.sd, std::sqrt(1.25));
  EXPECT_DOUBLE_EQ(s.min, 1);
  EXPECT_DOUBLE_EQ(s.max, 4);
  EXPECT_DOUBLE_EQ(ComputeErrorStatistics({5, 1, 3}).median, 3);
  EXPECT_THROW(ComputeErrorStatistics({}), std::invalid_argument);
}

TEST(Ate, SelfIsZero) {
  const auto gt = MakePath(300);
  const AteResult r = ComputeAte(gt, gt);
  EXPECT_EQ(r.num_pairs, 300u);
  EXPECT_LT(r.error.rmse, 1e-12);
  EXPECT_LT(r.error.max, 1e-12);
  const RpeResult rpe = ComputeRpe(gt, gt);
  EXPECT_GT(rpe.num_pairs, 0u);
  EXPECT_LT(rpe.trans_rmse, 1e-12);
  EXPECT_LT(rpe.rot_rmse, 1e-5);  // acos near 1 amplifies rounding
}

TEST(Ate, RigidTransformIsRemoved) {
  const auto gt = MakePath(300);
  const Rigid3d est_from_gt = SomeTransform();
  std::vector<StampedPose> est = gt;
  for (StampedPose& p : est) p.world_from_cam = est_from_gt * p.world_from_cam;
  const AteResult r = ComputeAte(gt, est);
  EXPECT_EQ(r.num_pairs, 300u);
  EXPECT_LT(r.error.rmse, 1e-9);
  EXPECT_LT(r.error.max, 1e-9);
  const Rigid3d expected = est_from_gt.Inverse();
  EXPECT_LT((r.gt_from_est.translation - expected.translation).norm(), 1e-9);
  EXPECT_LT(r.gt_from_est.rotation.angularDistance(expected.rotation), 1e-9);
  ASSERT_EQ(r.aligned_estimate.size(), est.size());
  EXPECT_LT((r.aligned_estimate[17].world_from_cam.translation - gt[17].world_from_cam.translation)
                .norm(),
            1e-9);
  // RPE is invariant to a global rigid transform.
  const RpeResult rpe = ComputeRpe(gt, est);
  EXPECT_LT(rpe.trans_rmse, 1e-9);
}

TEST(Ate, IsotropicNoiseGivesExpectedRmse) {
  const auto gt = MakePath(3000, 33'333'333);
  std::mt19937 rng(42);
  const double sigma = 0.02;  // per axis: expected RMSE of 3D error = sigma * sqrt(3)
  std::normal_distribution<double> noise(0.0, sigma);
  std::vector<StampedPose> est = gt;
  const Rigid3d est_from_gt = SomeTransform();
  for (StampedPose& p : est) {
    p.world_from_cam.translation += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    p.world_from_cam = est_from_gt * p.world_from_cam;
  }
  const AteResult r = ComputeAte(gt, est);
  EXPECT_NEAR(r.error.rmse, sigma * std::sqrt(3.0), 0.03 * sigma * std::sqrt(3.0));
  // Maxwell distribution: mean = 2 sigma sqrt(2/pi).
  EXPECT_NEAR(r.error.mean, 2 * sigma * std::sqrt(2 / M_PI), 0.03 * sigma);
  EXPECT_GT(r.error.max, r.error.median);
  EXPECT_LE(r.error.min, r.error.median);
}

TEST(Ate, AssociatesWithinMaxDifference) {
  const auto gt = MakePath(100);
  std::vector<StampedPose> est = gt;
  for (StampedPose& p : est)
    p.stamp = Timestamp::FromNanoseconds(p.stamp.nanoseconds() + 15'000'000);
  EXPECT_EQ(ComputeAte(gt, est).num_pairs, 100u);  // 15 ms < 20 ms
  AteOptions o;
  o.offset = -0.015;
  EXPECT_LT(ComputeAte(gt, est, o).error.rmse, 1e-12);
  for (StampedPose& p : est)
    p.stamp = Timestamp::FromNanoseconds(p.stamp.nanoseconds() + 10'000'000);
  // 25 ms from one neighbour, 15 ms from the next: each estimate pairs with the next gt pose.
  const AteResult shifted = ComputeAte(gt, est);
  EXPECT_EQ(shifted.num_pairs, 99u);
  EXPECT_EQ(shifted.gt_stamps[0], gt[1].stamp);
  est = gt;
  for (StampedPose& p : est)
    p.stamp = Timestamp::FromNanoseconds(p.stamp.nanoseconds() + 20'000'000);
  // Exactly 20 ms from both neighbours: outside the strict bound.
  EXPECT_THROW(ComputeAte(gt, est), InputError);
}

TEST(Ate, RejectsUnsortedAndTooShort) {
  auto gt = MakePath(10);
  EXPECT_THROW(ComputeAte(gt, MakePath(2)), InputError);
  auto est = gt;
  std::swap(est[3], est[4]);
  EXPECT_THROW(ComputeAte(gt, est), InputError);
  AteOptions bad;
  bad.max_time_difference = 0;
  EXPECT_THROW(ComputeAte(gt, gt, bad), InvalidOptions);
}

TEST(Rpe, ConstantYawDriftGivesThatRatePerSecond) {
  const int n = 200;  // 8 s at 25 Hz: delta 1 s = 25 steps exactly
  const auto gt = MakePath(n);
  const double rate_deg = 2.0;
  std::vector<StampedPose> est = gt;
  for (int i = 0; i < n; ++i) {
    const double t = i * 0.04;
    const Rigid3d drift(
        Eigen::Quaterniond(Eigen::AngleAxisd(rate_deg * M_PI / 180 * t, Eigen::Vector3d::UnitZ())),
        Eigen::Vector3d::Zero());
    est[i].world_from_cam = drift * gt[i].world_from_cam;
  }
  const RpeResult r = ComputeRpe(gt, est);
  // Pairs (i, i+25) except those whose partner is the last pose: n - 26.
  EXPECT_EQ(r.num_pairs, static_cast<size_t>(n - 26));
  EXPECT_NEAR(r.rot_rmse, rate_deg, 1e-6);
  EXPECT_NEAR(r.rot_median, rate_deg, 1e-6);
}

TEST(Rpe, ConstantPositionDriftGivesThatSpeed) {
  const int n = 200;
  const auto gt = MakePath(n);
  std::vector<StampedPose> est = gt;
  const double speed = 0.05;  // m/s along world x
  for (int i = 0; i < n; ++i) est[i].world_from_cam.translation.x() += speed * i * 0.04;
  const RpeResult r = ComputeRpe(gt, est);
  EXPECT_NEAR(r.trans_rmse, speed, 1e-9);
  EXPECT_NEAR(r.trans_mean, speed, 1e-9);
  EXPECT_LT(r.rot_rmse, 1e-5);
  // Shorter than delta: no pairs, no error.
  EXPECT_EQ(ComputeRpe(MakePath(20), MakePath(20)).num_pairs, 0u);
}

// Ground truth of a body mounted on the camera with a fixed offset: RPE against it measures the
// offset, not the estimate; moved to the camera with the right calibration the error vanishes,
// and ATE (rigid alignment) changes only by the lever arm.
TEST(GroundTruthCalibration, MovingTheBodyToTheCameraRemovesTheOffsetFromRpe) {
  const auto camera = MakePath(300);
  const Rigid3d body_from_cam = SomeTransform();
  std::vector<StampedPose> body = camera;
  for (StampedPose& p : body) p.world_from_cam = p.world_from_cam * body_from_cam.Inverse();
  const RpeResult raw = ComputeRpe(body, camera);
  EXPECT_GT(raw.rot_rmse, 1.0);  // degrees per second
  const RpeResult moved = ComputeRpe(MoveGroundTruthToCamera(body, body_from_cam), camera);
  EXPECT_EQ(moved.num_pairs, raw.num_pairs);
  EXPECT_LT(moved.rot_rmse, 1e-5);
  EXPECT_LT(moved.trans_rmse, 1e-9);
  EXPECT_LT(ComputeAte(MoveGroundTruthToCamera(body, body_from_cam), camera).error.rmse, 1e-9);
}

// The Bonn marker-to-camera calibration is the published T_ros * T_m with its 3x3 block made a
// rotation: a camera pose from it equals the published T_ros * T_i * T_ros * T_m up to the world
// turn T_ros, position exactly and orientation up to the block's scale.
TEST(GroundTruthCalibration, BonnMarkerFromCameraIsThePublishedTransform) {
  const Rigid3d x = BonnMarkerFromCamera();
  EXPECT_NEAR(x.rotation.norm(), 1.0, 1e-12);
  EXPECT_NEAR(x.RotationMatrix().determinant(), 1.0, 1e-9);
  Eigen::Matrix4d t_ros, t_m;
  t_ros << -1, 0, 0, 0, 0, 0, 1, 0, 0, 1, 0, 0, 0, 0, 0, 1;
  t_m << 1.0157, 0.1828, -0.2389, 0.0113, 0.0009, -0.8431, -0.6413, -0.0098, -0.3009, 0.6147,
      -0.8085, 0.0111, 0, 0, 0, 1;
  for (const StampedPose& marker : MakePath(50)) {
    const Eigen::Matrix4d published = t_ros * marker.world_from_cam.ToMatrix() * t_ros * t_m;
    const Eigen::Matrix4d ours = t_ros * (marker.world_from_cam * x).ToMatrix();
    EXPECT_LT((published.topRightCorner<3, 1>() - ours.topRightCorner<3, 1>()).norm(), 1e-12);
    const Eigen::Matrix3d block = published.topLeftCorner<3, 3>();
    const double scale = std::cbrt(block.determinant());
    EXPECT_NEAR(scale, 1.0593, 1e-3);
    EXPECT_LT((block / scale - ours.topLeftCorner<3, 3>()).cwiseAbs().maxCoeff(), 1e-3);
  }
  // The marker sits 19 mm from the optical centre, turned by about 173 degrees.
  EXPECT_NEAR(x.translation.norm(), 0.0186, 0.0005);
  EXPECT_NEAR(RotationAngle(x.rotation) * 180 / M_PI, 172.7, 0.1);
}

}  // namespace
}  // namespace dygslam
