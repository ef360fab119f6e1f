// Relocalization through the bag-of-words index on a generated keyframe map: same success and
// accuracy as brute force, and the index does not touch keyframes that share no words.
#include "core/slam/tracking/relocalization.h"

#include <gtest/gtest.h>

#include "tests/slam/synthetic_map.h"

namespace dygslam {
namespace {

TEST(Relocalization, BowIndexFindsThePoseLikeBruteForce) {
  const Vocabulary vocabulary =
      Vocabulary::Load(std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/vocabulary.dygvoc");
  const OrbExtractor extractor{OrbExtractorOptions{}};
  SyntheticOptions synth;
  synth.seed = 5;
  synth.num_moving_objects = 0;
  synth.supersampling = 1;
  synth.num_frames = 121;
  const SyntheticScene scene(synth);
  testing::SyntheticMap map;
  testing::BuildSyntheticMap(scene, 30, 4, vocabulary, extractor, &map);  // frames 0..116
  SyntheticOptions noisy = synth;
  noisy.rgb_noise_sigma = 3.0;
  const SyntheticScene noisy_scene(noisy);
  TrackingOptions options;
  const Matcher matcher(options.matcher);
  std::lock_guard<std::mutex> lock(map.map->mutex());
  int ok_bow = 0, ok_brute = 0;
  const std::vector<int> queries = {42, 61, 78, 97, 114};  // 40+ frames after a keyframe, none one
  for (int q : queries) {
    const Frame query = testing::MakeSyntheticFrame(noisy_scene, noisy_scene.RenderFrame(q),
                                                    1000 + q, extractor, map.geometry);
    const Eigen::Vector3d truth = scene.WorldFromCam(q).translation;
    Frame a = query;
    const RelocalizationResult bow =
        RelocalizeFrame(a, *map.map, &map.database, &vocabulary, matcher, options);
    Frame b = query;
    const RelocalizationResult brute =
        RelocalizeFrame(b, *map.map, nullptr, nullptr, matcher, options);
    if (bow.ok) {
      ++ok_bow;
      // Keyframes are ground truth: the pose is exact up to feature noise (measured < 1 cm).
      EXPECT_LT((a.CameraCenter() - truth).norm(), 0.03) << "frame " << q;
      EXPECT_GE(bow.inliers, options.relocalized_min_inliers);
      // The keyframe used lies near the query (within 20 frames of the path).
      EXPECT_LE(std::abs(bow.keyframe->frame_id - q), 20) << "frame " << q;
    }
    if (brute.ok) {
      ++ok_brute;
      EXPECT_LT((b.CameraCenter() - truth).norm(), 0.03) << "frame " << q;
    }
  }
  EXPECT_EQ(ok_bow, static_cast<int>(queries.size()));
  EXPECT_EQ(ok_brute, static_cast<int>(queries.size()));
  // A uniform grey frame has no features: no candidate, no pose, no crash.
  OrbFeatures none;
  Frame blank(5000, scene.FrameStamp(0), none, cv::Mat(480, 640, CV_32F, cv::Scalar(0)),
              map.geometry);
  EXPECT_FALSE(RelocalizeFrame(blank, *map.map, &map.database, &vocabulary, matcher, options).ok);
  EXPECT_FALSE(blank.has_pose);
}

}  // namespace
}  // namespace dygslam
