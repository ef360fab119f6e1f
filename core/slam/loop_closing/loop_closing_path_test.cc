// Loop closing bookkeeping without images: the keyframe path that decides whether an old
// covisible keyframe is a revisit (culled keyframes count), and the run summary's rejection line.
#include <gtest/gtest.h>

#include <string>

#include "core/slam/loop_closing/loop_closing.h"

namespace dygslam {
namespace {

std::shared_ptr<const CameraGeometry> Geometry() {
  PinholeCamera cam;
  cam.fx = cam.fy = 500;
  cam.cx = 320;
  cam.cy = 240;
  OrbExtractor extractor{OrbExtractorOptions{}};
  return std::make_shared<CameraGeometry>(
      CameraGeometry::Create(cam, RgbdSensorOptions{}, extractor));
}

// A keyframe whose camera centre is `center` (no rotation), with a few features.
std::shared_ptr<KeyFrame> AddKeyFrameAt(Map& map, const Eigen::Vector3d& center) {
  OrbFeatures f;
  for (int i = 0; i < 5; ++i) {
    cv::KeyPoint kp(cv::Point2f(10.f + i, 10.f + i), 31.f);
    kp.octave = 0;
    f.keypoints.push_back(kp);
    f.descriptors.push_back(Descriptor{uint64_t(i), 0, 0, 0});
  }
  Frame frame(static_cast<int64_t>(map.NumKeyFrames()),
              Timestamp::FromNanoseconds(static_cast<int64_t>(map.NumKeyFrames()) + 1), f,
              cv::Mat(480, 640, CV_32F, cv::Scalar(2.0f)), Geometry());
  frame.cam_from_world = Rigid3d(Eigen::Quaterniond::Identity(), -center);
  auto kf = std::make_shared<KeyFrame>(map.NextKeyFrameId(), frame);
  map.AddKeyFrame(kf);
  return kf;
}

TEST(LoopClosingPath, CulledKeyFramesStillCountAlongThePath) {
  // A zigzag of 0.5 m legs: 0 -> (0.3, 0.4) -> (0.6, 0) -> (0.9, 0.4) -> (1.2, 0); 4 legs, 2.0 m.
  Map map;
  std::vector<std::shared_ptr<KeyFrame>> kfs;
  for (int k = 0; k < 5; ++k)
    kfs.push_back(AddKeyFrameAt(map, Eigen::Vector3d(0.3 * k, k % 2 ? 0.4 : 0.0, 0)));
  EXPECT_NEAR(KeyFramePathLength(map, kfs[0]->id, kfs[4]->id), 2.0, 1e-9);
  EXPECT_NEAR(KeyFramePathLength(map, kfs[2]->id, kfs[4]->id), 1.0, 1e-9);
  // Culling the corners keeps their poses (via the parent): the path is still 2.0 m, not the
  // 1.2 m straight line between the keyframes left.
  map.SetBad(kfs[1]);
  map.SetBad(kfs[3]);
  ASSERT_TRUE(map.IsCulled(kfs[1]->id));
  ASSERT_EQ(map.NumKeyFrames(), 3u);
  EXPECT_NEAR(KeyFramePathLength(map, kfs[0]->id, kfs[4]->id), 2.0, 1e-9);
  EXPECT_NEAR(KeyFramePathLength(map, kfs[1]->id, kfs[4]->id), 1.5, 1e-9);
  // A keyframe that was never made has no path.
  EXPECT_EQ(KeyFramePathLength(map, 99, 120), 0.0);
  EXPECT_EQ(KeyFramePathLength(map, kfs[4]->id, kfs[4]->id), 0.0);
}

TEST(LoopClosingPath, RejectionSummaryNamesTheStrongestRejectedCandidate) {
  LoopClosingStats stats;
  EXPECT_EQ(LoopRejectionSummary(stats), "");  // nothing verified: no line
  stats.rejected_bow = 2;
  stats.rejected_inliers = 1;
  LoopVerification weak, strong, accepted;
  weak.frame_id = 300;
  weak.loop_frame_id = 210;
  weak.bow_pairs = 9;
  weak.verdict = "BoW matches";
  strong.frame_id = 587;
  strong.loop_frame_id = 0;
  strong.bow_pairs = 60;
  strong.inliers = 31;
  strong.verdict = "inliers";
  accepted.frame_id = 600;
  accepted.inliers = 90;
  accepted.verdict = "accepted";
  stats.verifications = {weak, strong, accepted, weak};
  const std::string line = LoopRejectionSummary(stats);
  EXPECT_NE(line.find("2 BoW matches, 1 inliers, 0 inlier ratio"), std::string::npos) << line;
  // The accepted verification (90 inliers) is not a rejection; 587 vs 0 is the strongest.
  EXPECT_NE(line.find("strongest: frame 587 vs frame 0: 31 / 60 inliers"), std::string::npos)
      << line;
  EXPECT_EQ(line.substr(line.size() - 9), ": inliers") << line;
}

}  // namespace
}  // namespace dygslam
