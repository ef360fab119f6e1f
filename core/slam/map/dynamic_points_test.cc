// The dynamic map-point vote (core/slam/map/dynamic_points.h) on a handmade map: which points get
// flagged and taken out of the map, and which survive a wrong label.
#include "core/slam/map/dynamic_points.h"

#include <gtest/gtest.h>

#include "core/base/error.h"

namespace dygslam {
namespace {

std::shared_ptr<KeyFrame> KeyFrameWithPoints(Map& map, int n) {
  PinholeCamera cam;
  cam.fx = cam.fy = 500;
  cam.cx = 320;
  cam.cy = 240;
  const OrbExtractor extractor{OrbExtractorOptions{}};
  auto geometry =
      std::make_shared<CameraGeometry>(CameraGeometry::Create(cam, RgbdSensorOptions{}, extractor));
  OrbFeatures f;
  for (int i = 0; i < n; ++i) {
    f.keypoints.emplace_back(cv::Point2f(10.f + 5 * i, 20.f), 31.f);
    f.descriptors.push_back(Descriptor{uint64_t(i), 0, 0, 0});
  }
  Frame frame(7, Timestamp::FromNanoseconds(1), f, cv::Mat(480, 640, CV_32F, cv::Scalar(2.0f)),
              geometry);
  auto kf = std::make_shared<KeyFrame>(map.NextKeyFrameId(), frame);
  map.AddKeyFrame(kf);
  for (int i = 0; i < n; ++i) {
    auto mp = std::make_shared<MapPoint>(map.NextMapPointId(), Eigen::Vector3d(0, 0, 2), kf->id);
    map.AddMapPoint(mp);
    map.AddObservation(mp, kf, i);
  }
  return kf;
}

TEST(DynamicMapPoints, VotesFollowTheFilterTracks) {
  Map map;
  const auto kf = KeyFrameWithPoints(map, 4);
  // The previous frame: feature 0 -> point 0, feature 1 -> point 1, feature 2 none, 3 -> point 3.
  std::vector<std::shared_ptr<MapPoint>> previous(4);
  previous[0] = kf->map_points[0];
  previous[1] = kf->map_points[1];
  previous[3] = kf->map_points[3];
  DynamicPointOptions options;
  options.min_votes = 1;
  options.min_dynamic_fraction = 0.5;
  DynamicPointVoter voter(options);
  // Point 3 was seen static three times before.
  for (int k = 0; k < 3; ++k) voter.Vote(map, previous, {-1, -1, -1, 3}, {0, 0, 0, 0});
  EXPECT_EQ(kf->map_points[3]->static_votes, 3);
  // This frame: feature 0 continues 1 (dynamic), feature 1 continues 2 (no point, dynamic),
  // feature 2 continues 0 (static), feature 3 continues 3 (dynamic, once, after 3 static votes).
  const auto point1 = kf->map_points[1];
  const auto point3 = kf->map_points[3];
  EXPECT_EQ(voter.Vote(map, previous, {1, 2, 0, 3}, {1, 1, 0, 1}), 1);
  EXPECT_TRUE(point1->is_dynamic);
  EXPECT_TRUE(point1->bad);
  EXPECT_EQ(map.NumMapPoints(), 3u);
  EXPECT_EQ(kf->map_points[1], nullptr);
  ASSERT_EQ(voter.flagged().size(), 1u);
  EXPECT_EQ(voter.flagged()[0].point_id, point1->id);
  EXPECT_EQ(voter.flagged()[0].frame_id, 7);
  EXPECT_FLOAT_EQ(voter.flagged()[0].pixel.x, 15.f);
  EXPECT_FALSE(point3->is_dynamic);  // 1 dynamic of 4 votes
  EXPECT_EQ(point3->dynamic_votes, 1);
  EXPECT_EQ(kf->map_points[0]->static_votes, 1);
  // Sizes that do not fit: no votes, no crash.
  EXPECT_EQ(voter.Vote(map, previous, {0, 1}, {1}), 0);
  EXPECT_EQ(voter.Vote(map, previous, {9, -4}, {1, 1}), 0);
  options.min_votes = 0;
  EXPECT_THROW(DynamicPointVoter{options}, InvalidOptions);
}

}  // namespace
}  // namespace dygslam
