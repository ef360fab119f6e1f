// Map bookkeeping: observations, covisibility, replacement, keyframe culling and resolved poses.
#include "core/slam/map/map.h"

#include <gtest/gtest.h>

#include "core/slam/feature/matcher.h"

namespace dygslam {
namespace {

std::shared_ptr<const CameraGeometry> Geometry() {
  PinholeCamera cam;
  cam.fx = cam.fy = 500;
  cam.cx = 320;
  cam.cy = 240;
  OrbExtractor extractor{OrbExtractorOptions{}};
  return std::make_shared<CameraGeometry>(CameraGeometry::Create(cam, RgbdSensorOptions{}, extractor));
}

std::shared_ptr<KeyFrame> MakeKeyFrame(Map& map, int n, const Rigid3d& cam_from_world) {
  OrbFeatures f;
  for (int i = 0; i < n; ++i) {
    cv::KeyPoint kp(cv::Point2f(10.f + i, 10.f + i), 31.f);
    kp.octave = 0;
    f.keypoints.push_back(kp);
    f.descriptors.push_back(Descriptor{uint64_t(i), 0, 0, 0});
  }
  Frame frame(0, Timestamp::FromNanoseconds(map.NumKeyFrames() + 1), f, cv::Mat(480, 640, CV_32F, cv::Scalar(2.0f)), Geometry());
  frame.cam_from_world = cam_from_world;
  auto kf = std::make_shared<KeyFrame>(map.NextKeyFrameId(), frame);
  map.AddKeyFrame(kf);
  return kf;
}

TEST(Map, CovisibilityWeightsFollowSharedPoints) {
  Map map;
  auto a = MakeKeyFrame(map, 40, Rigid3d());
  auto b = MakeKeyFrame(map, 40, Rigid3d());
  auto c = MakeKeyFrame(map, 40, Rigid3d());
  for (int i = 0; i < 40; ++i) {
    auto mp = std::make_shared<MapPoint>(map.NextMapPointId(), Eigen::Vector3d(0, 0, 2), a->id);
    map.AddMapPoint(mp);
    map.AddObservation(mp, a, i);
    if (i < 30) map.AddObservation(mp, b, i);
    if (i < 16) map.AddObservation(mp, c, i);
  }
  map.UpdateConnections(a);
  map.UpdateConnections(b);
  map.UpdateConnections(c);
  EXPECT_EQ(a->connection_weights.at(b->id), 30);
  EXPECT_EQ(a->connection_weights.at(c->id), 16);
  ASSERT_EQ(a->ordered_connections.size(), 2u);
  EXPECT_EQ(a->ordered_connections[0], b->id);  // heavier link first
  EXPECT_EQ(b->connection_weights.at(c->id), 16);
}

TEST(Map, ReplaceMergesObservationsAndErasingLastButOneDropsPoint) {
  Map map;
  auto a = MakeKeyFrame(map, 5, Rigid3d());
  auto b = MakeKeyFrame(map, 5, Rigid3d());
  auto p = std::make_shared<MapPoint>(map.NextMapPointId(), Eigen::Vector3d(0, 0, 2), a->id);
  auto q = std::make_shared<MapPoint>(map.NextMapPointId(), Eigen::Vector3d(0, 0, 2), b->id);
  map.AddMapPoint(p);
  map.AddMapPoint(q);
  map.AddObservation(p, a, 0);
  map.AddObservation(q, b, 1);
  map.Replace(p, q);
  EXPECT_TRUE(p->bad);
  EXPECT_EQ(p->replaced_by, q);
  EXPECT_EQ(q->NumObservations(), 2);
  EXPECT_EQ(a->map_points[0], q);
  EXPECT_EQ(map.map_points().count(p->id), 0u);
  map.EraseObservation(q, a->id);  // one observation left: no constraint, point dropped
  EXPECT_TRUE(q->bad);
  EXPECT_EQ(b->map_points[1], nullptr);
}

TEST(Map, CulledKeyFramePoseFollowsItsParent) {
  Map map;
  auto a = MakeKeyFrame(map, 30, Rigid3d());
  auto b = MakeKeyFrame(map, 30, Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(1, 0, 0)));
  auto c = MakeKeyFrame(map, 30, Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(2, 0, 0)));
  for (int i = 0; i < 30; ++i) {
    auto mp = std::make_shared<MapPoint>(map.NextMapPointId(), Eigen::Vector3d(0, 0, 2), a->id);
    map.AddMapPoint(mp);
    map.AddObservation(mp, a, i);
    map.AddObservation(mp, b, i);
    map.AddObservation(mp, c, i);
  }
  map.UpdateConnections(a);
  map.UpdateConnections(b);
  map.UpdateConnections(c);
  const Rigid3d b_before = map.ResolvedPose(b->id);
  map.SetBad(b);
  EXPECT_TRUE(b->bad);
  EXPECT_EQ(map.NumKeyFrames(), 2u);
  EXPECT_TRUE(map.ResolvedPose(b->id).translation.isApprox(b_before.translation));
  // Moving the parent moves the culled keyframe with it.
  auto parent = map.GetKeyFrame(b->parent_id);
  parent->cam_from_world.translation += Eigen::Vector3d(0, 0.5, 0);
  EXPECT_NEAR((map.ResolvedPose(b->id).translation - b_before.translation).norm(), 0.5, 1e-9);
  // The first keyframe is never culled.
  map.SetBad(a);
  EXPECT_FALSE(a->bad);
}

TEST(Matcher, RotationConsistencyKeepsDominantBins) {
  std::vector<float> rotations;
  for (int i = 0; i < 50; ++i) rotations.push_back(10.f + 0.1f * i);   // dominant (~10-15 deg)
  for (int i = 0; i < 3; ++i) rotations.push_back(180.f);              // a few wrong ones
  const auto drop = RotationConsistencyOutliers(rotations);
  // The dominant bin survives; the tiny 180-degree group (< 10 % of the top bin) is dropped.
  for (int k : drop) EXPECT_GE(k, 50);
  EXPECT_EQ(drop.size(), 3u);
}

}  // namespace
}  // namespace dygslam
