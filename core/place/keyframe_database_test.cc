#include "core/place/keyframe_database.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "tools/synth/synthetic_scene.h"
#include "tools/vocab/synthetic_training.h"

namespace dygslam {
namespace {

// 12 views along one synthetic path (every 45th frame, a scene not used for training) as
// keyframes; queries are the same views re-rendered with colour noise (other features).
class KeyFrameDatabaseTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    // The shipped vocabulary (trained on other synthetic scenes, see `dygslam vocab`).
    vocabulary_ = new Vocabulary(
        Vocabulary::Load(std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/vocabulary.dygvoc"));
    keyframes_ = new std::vector<BowVector>(Views(0.0));
    queries_ = new std::vector<BowVector>(Views(4.0));
  }
  static void TearDownTestSuite() {
    delete vocabulary_;
    delete keyframes_;
    delete queries_;
  }
  static std::vector<BowVector> Views(double noise) {
    SyntheticOptions o;
    o.seed = 21;
    o.num_frames = kViews * kStride;
    o.num_moving_objects = 0;
    o.supersampling = 1;
    o.rgb_noise_sigma = noise;
    const SyntheticScene scene(o);
    const OrbExtractor extractor{OrbExtractorOptions{}};
    std::vector<BowVector> out;
    for (int i = 0; i < kViews; ++i) {
      cv::Mat gray;
      cv::cvtColor(scene.RenderFrame(i * kStride).rgb, gray, cv::COLOR_BGR2GRAY);
      BowVector bow;
      vocabulary_->Transform(extractor.Extract(gray).descriptors, &bow);
      out.push_back(bow);
    }
    return out;
  }
  static constexpr int kViews = 12, kStride = 45;
  static Vocabulary* vocabulary_;
  static std::vector<BowVector>* keyframes_;
  static std::vector<BowVector>* queries_;
};
Vocabulary* KeyFrameDatabaseTest::vocabulary_ = nullptr;
std::vector<BowVector>* KeyFrameDatabaseTest::keyframes_ = nullptr;
std::vector<BowVector>* KeyFrameDatabaseTest::queries_ = nullptr;

TEST_F(KeyFrameDatabaseTest, QueryFindsTheSameView) {
  KeyFrameDatabase db;
  for (int i = 0; i < kViews; ++i) db.Add(100 + i, (*keyframes_)[i]);
  EXPECT_EQ(db.size(), static_cast<size_t>(kViews));
  PlaceQueryOptions q;
  q.max_results = 3;
  int top1 = 0;
  for (int i = 0; i < kViews; ++i) {
    const auto c = db.Query((*queries_)[i], q);
    ASSERT_FALSE(c.empty());
    EXPECT_TRUE(std::is_sorted(c.begin(), c.end(),
                               [](const auto& a, const auto& b) { return a.score > b.score; }));
    EXPECT_NEAR(c[0].score, db.ScoreAgainst((*queries_)[i], c[0].keyframe_id), 1e-12);
    top1 += c[0].keyframe_id == 100 + i;
  }
  // Views 1.5 s apart on a handheld path overlap; the same view must still win almost always.
  EXPECT_GE(top1, kViews - 1);
}

TEST_F(KeyFrameDatabaseTest, EraseAndExclude) {
  KeyFrameDatabase db;
  for (int i = 0; i < kViews; ++i) db.Add(100 + i, (*keyframes_)[i]);
  PlaceQueryOptions q;
  q.max_results = kViews;
  q.min_common_words_ratio = 0;
  const auto all = db.Query((*queries_)[5], q);
  EXPECT_EQ(all[0].keyframe_id, 105);
  db.Erase(105);
  db.Erase(105);  // twice: no effect
  EXPECT_EQ(db.size(), static_cast<size_t>(kViews - 1));
  for (const auto& c : db.Query((*queries_)[5], q)) EXPECT_NE(c.keyframe_id, 105);
  EXPECT_EQ(db.ScoreAgainst((*queries_)[5], 105), 0.0);
  const auto excluded =
      db.Query((*queries_)[6], q, [](int64_t id) { return id == 106 || id == 107; });
  for (const auto& c : excluded) EXPECT_TRUE(c.keyframe_id != 106 && c.keyframe_id != 107);
  // min_score filters.
  q.min_score = 0.99;
  EXPECT_TRUE(db.Query((*queries_)[6], q).empty());
  db.Clear();
  EXPECT_EQ(db.size(), 0u);
  EXPECT_TRUE(db.Query((*queries_)[6], PlaceQueryOptions{}).empty());
}

}  // namespace
}  // namespace dygslam
