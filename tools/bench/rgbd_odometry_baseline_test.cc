#include "tools/bench/rgbd_odometry_baseline.h"

#include <gtest/gtest.h>

#include "core/base/error.h"
#include "core/eval/trajectory_eval.h"
#include "tools/synth/synthetic_scene.h"

namespace dygslam {
namespace {

// On a generated static sequence the odometry follows the known camera path: poses are relative
// to the first frame (no alignment needed), so this also pins the direction convention.
TEST(RgbdOdometryBaseline, FollowsGeneratedStaticSequence) {
  SyntheticOptions synth;
  synth.num_frames = 30;
  synth.num_moving_objects = 0;
  synth.seed = 5;
  synth.supersampling = 1;
  SyntheticScene scene(synth);
  RgbdOdometryBaseline odometry(synth.camera, synth.sensor.depth_map_factor);
  const Rigid3d first_from_world = scene.WorldFromCam(0).Inverse();
  double max_error = 0, path_length = 0;
  Eigen::Vector3d previous = Eigen::Vector3d::Zero();
  for (int i = 0; i < scene.num_frames(); ++i) {
    const SyntheticFrame f = scene.RenderFrame(i);
    const OdometryStep step = odometry.Track(f.rgb, f.depth, f.stamp);
    EXPECT_TRUE(step.ok) << "frame " << i;
    EXPECT_GT(step.time_ms, 0);
    const Rigid3d expected = first_from_world * scene.WorldFromCam(i);
    max_error =
        std::max(max_error, (step.world_from_cam.translation - expected.translation).norm());
    EXPECT_LT(RotationAngle(step.world_from_cam.rotation.inverse() * expected.rotation),
              0.5 * M_PI / 180)
        << "frame " << i;
    path_length += (expected.translation - previous).norm();
    previous = expected.translation;
  }
  std::cout << "odometry on 30 generated frames: max position error " << max_error << " m over a "
            << path_length << " m path\n";
  EXPECT_GT(path_length, 0.05);  // the camera really moved
  EXPECT_LT(max_error, 0.01);
  EXPECT_EQ(odometry.Trajectory().size(), 30u);
  EXPECT_EQ(odometry.num_failed(), 0);
}

TEST(RgbdOdometryBaseline, RejectsBadInput) {
  const PinholeCamera camera = DefaultSyntheticCamera();
  RgbdOdometryBaseline odometry(camera, 5000.0);
  const cv::Mat rgb(480, 640, CV_8UC3, cv::Scalar(0, 0, 0));
  EXPECT_THROW(odometry.Track(rgb, cv::Mat(), Timestamp()), InputError);
  EXPECT_THROW(odometry.Track(cv::Mat(240, 320, CV_8UC3), cv::Mat(240, 320, CV_16UC1), Timestamp()),
               InputError);
  RgbdOdometryOptions bad;
  bad.max_depth = -1;
  EXPECT_THROW(RgbdOdometryBaseline(camera, 5000.0, bad), InvalidOptions);
  EXPECT_THROW(RgbdOdometryBaseline(camera, 0.0), InvalidOptions);
}

}  // namespace
}  // namespace dygslam
