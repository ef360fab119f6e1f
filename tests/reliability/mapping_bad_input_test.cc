// Absurd keyframes into the map (what a mapper may receive from any slam on the domain after
// convert.h's checks, which only require finite values): far-away poses, absurd depth values,
// masks of the wrong size. A clear InputError or a bounded map -- never a crash or a map that
// explodes in size.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <string>

#include "core/base/error.h"
#include "mapping/octomap_builder.h"

namespace dygslam {
namespace {

PinholeCamera Camera() {
  PinholeCamera c;
  c.fx = c.fy = 80;
  c.cx = 40;
  c.cy = 30;
  c.width = 80;
  c.height = 60;
  return c;
}

KeyframeData Keyframe(int64_t id, const Eigen::Vector3d& t, float depth_m) {
  KeyframeData k;
  k.id = id;
  k.world_from_cam = Rigid3d(Eigen::Quaterniond::Identity(), t);
  k.rgb = cv::Mat(60, 80, CV_8UC3, cv::Scalar(50, 60, 70));
  k.depth = cv::Mat(60, 80, CV_32FC1, cv::Scalar(depth_m));
  return k;
}

TEST(MappingBadInput, FarAwayPosesAndAbsurdDepthKeepTheMapBounded) {
  OctoMapBuilder builder(Camera());
  builder.Insert(Keyframe(0, Eigen::Vector3d::Zero(), 2.0f));
  const OctoMapStats normal = builder.Stats();
  ASSERT_GT(normal.num_occupied_leaves, 0u);
  int64_t id = 1;
  // Poses far outside any octree (octomap keys cover about +-1600 m at 5 cm).
  for (double far : {1e4, 1e7, 1e30, 1e300}) {
    try {
      builder.Insert(Keyframe(id++, Eigen::Vector3d(far, -far, far), 2.0f));
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("keyframe"), std::string::npos) << e.what();
    }
  }
  // Absurd depth values: huge, NaN, inf, negative, denormal.
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (float d : {1e30f, nan, std::numeric_limits<float>::infinity(), -5.0f, 1e-40f, 0.0f}) {
    builder.Insert(Keyframe(id++, Eigen::Vector3d(0.1, 0, 0), d));
  }
  // Mixed NaN / huge pixels inside a normal image.
  KeyframeData mixed = Keyframe(id++, Eigen::Vector3d(0, 0.1, 0), 2.0f);
  for (int y = 0; y < 60; y += 3)
    for (int x = 0; x < 80; x += 5) mixed.depth.at<float>(y, x) = (x + y) % 2 ? nan : 1e20f;
  builder.Insert(mixed);
  const OctoMapStats after = builder.Stats();
  EXPECT_LT(after.memory_bytes, 50u * 1024 * 1024) << "the map exploded";
  EXPECT_LT(after.num_occupied_leaves, 20 * normal.num_occupied_leaves + 1000);
}

TEST(MappingBadInput, WrongSizesAndNonFinitePosesAreInputErrors) {
  OctoMapBuilder builder(Camera());
  KeyframeData k = Keyframe(1, Eigen::Vector3d::Zero(), 2.0f);
  k.depth = cv::Mat(30, 40, CV_32FC1, cv::Scalar(2.0f));
  EXPECT_THROW(builder.Insert(k), InputError);
  k = Keyframe(2, Eigen::Vector3d::Zero(), 2.0f);
  k.dynamic_mask = cv::Mat::zeros(10, 10, CV_8UC1);
  EXPECT_THROW(builder.Insert(k), InputError);
  k = Keyframe(3, Eigen::Vector3d::Zero(), 2.0f);
  k.depth = cv::Mat(60, 80, CV_16UC1, cv::Scalar(5000));
  EXPECT_THROW(builder.Insert(k), InputError);
  k = Keyframe(4, Eigen::Vector3d(std::numeric_limits<double>::quiet_NaN(), 0, 0), 2.0f);
  EXPECT_THROW(builder.Insert(k), InputError);
  k = Keyframe(5, Eigen::Vector3d::Zero(), 2.0f);
  k.keypoints.resize(3);
  k.keypoint_dynamic.assign(2, 1);
  EXPECT_THROW(builder.Insert(k), InputError);
  // Keypoints far outside the image with the dynamic flag: ignored, no crash.
  k = Keyframe(6, Eigen::Vector3d::Zero(), 2.0f);
  k.keypoints = {cv::KeyPoint(1e9f, -1e9f, 7), cv::KeyPoint(-5, 70, 7)};
  k.keypoint_dynamic = {1, 1};
  EXPECT_NO_THROW(builder.Insert(k));
  EXPECT_EQ(builder.Stats().num_keyframes, 1u);
}

}  // namespace
}  // namespace dygslam
