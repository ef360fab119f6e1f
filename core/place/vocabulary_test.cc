#include "core/place/vocabulary.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <opencv2/imgproc.hpp>

#include "tests/support/test_support.h"
#include "tools/synth/synthetic_scene.h"
#include "tools/vocab/synthetic_training.h"

namespace dygslam {
namespace {

// A tiny vocabulary trained once for the suite (2 scenes x 4 frames, k = 8, L = 3) for the tree
// checks; scoring uses the shipped vocabulary (config/vocabulary.dygvoc, `dygslam vocab`).
class VocabularyTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    SyntheticTrainingOptions t;
    t.num_scenes = 2;
    t.frames_per_scene = 4;
    t.frame_stride = 200;
    training_ = new std::vector<std::vector<Descriptor>>(SyntheticTrainingDescriptors(t));
    VocabularyOptions v;
    v.branching = 8;
    v.depth = 3;
    vocabulary_ = new Vocabulary(Vocabulary::Train(*training_, v));
    shipped_ = new Vocabulary(
        Vocabulary::Load(std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/vocabulary.dygvoc"));
  }
  static void TearDownTestSuite() {
    delete vocabulary_;
    delete training_;
    delete shipped_;
  }
  // ORB descriptors of frame `index` of a scene never used for training.
  static std::vector<Descriptor> QueryImage(uint64_t seed, int index, double rgb_noise) {
    SyntheticOptions o;
    o.seed = seed;
    o.num_frames = index + 1;
    o.num_moving_objects = 0;
    o.supersampling = 1;
    o.rgb_noise_sigma = rgb_noise;
    const SyntheticFrame f = SyntheticScene(o).RenderFrame(index);
    cv::Mat gray;
    cv::cvtColor(f.rgb, gray, cv::COLOR_BGR2GRAY);
    return OrbExtractor(OrbExtractorOptions{}).Extract(gray).descriptors;
  }
  static std::vector<std::vector<Descriptor>>* training_;
  static Vocabulary* vocabulary_;
  static Vocabulary* shipped_;
};
std::vector<std::vector<Descriptor>>* VocabularyTest::training_ = nullptr;
Vocabulary* VocabularyTest::vocabulary_ = nullptr;
Vocabulary* VocabularyTest::shipped_ = nullptr;

TEST_F(VocabularyTest, TreeShapeAndIdfWeights) {
  const Vocabulary& v = *vocabulary_;
  ASSERT_FALSE(v.empty());
  EXPECT_EQ(v.branching(), 8);
  EXPECT_EQ(v.depth(), 3);
  // 8 images x ~1000 descriptors fill most of the 512 possible leaves.
  EXPECT_GT(v.NumWords(), 300u);
  EXPECT_LE(v.NumWords(), 512u);
  EXPECT_LE(v.NumNodes(), 1u + 8u + 64u + 512u);
  // IDF: every word seen in training has weight log(N / n_i) in [0, log(8)].
  for (WordId w = 0; w < v.NumWords(); ++w) {
    EXPECT_GE(v.WordWeight(w), 0.0);
    EXPECT_LE(v.WordWeight(w), std::log(8.0) + 1e-6);
  }
  // A training descriptor lands on a leaf whose ancestors are at the requested levels.
  NodeId level1 = 0, level3 = 0;
  const WordId w = v.Transform((*training_)[0][0], 1, &level1);
  EXPECT_EQ(v.Transform((*training_)[0][0], 3, &level3), w);
  EXPECT_GE(level1, 1u);
  EXPECT_LE(level1, 8u);
  EXPECT_GT(level3, 8u);
}

TEST_F(VocabularyTest, TrainingIsDeterministic) {
  VocabularyOptions o;
  o.branching = 8;
  o.depth = 3;
  const std::vector<std::vector<Descriptor>> part(training_->begin(), training_->begin() + 4);
  EXPECT_EQ(Vocabulary::Train(part, o).Checksum(), Vocabulary::Train(part, o).Checksum());
  o.seed = 2;
  EXPECT_NE(Vocabulary::Train(part, o).Checksum(),
            Vocabulary::Train(part, VocabularyOptions{}).Checksum());
}

TEST_F(VocabularyTest, SameViewScoresHigherThanOtherScene) {
  const Vocabulary& v = *shipped_;
  BowVector a, a_noisy, b, c;
  v.Transform(QueryImage(7, 30, 0.0), &a);
  v.Transform(QueryImage(7, 30, 4.0), &a_noisy);  // same view, colour noise: other features
  v.Transform(QueryImage(8, 30, 0.0), &b);        // other textures, same camera path
  v.Transform(QueryImage(7, 240, 0.0), &c);       // same room, other view (8 s later)
  double norm = 0;
  for (const auto& [w, x] : a) norm += x;
  EXPECT_NEAR(norm, 1.0, 1e-9);
  EXPECT_NEAR(Vocabulary::Score(a, a), 1.0, 1e-9);
  const double same = Vocabulary::Score(a, a_noisy);
  const double other_scene = Vocabulary::Score(a, b);
  const double other_view = Vocabulary::Score(a, c);
  EXPECT_NEAR(Vocabulary::Score(a, b), Vocabulary::Score(b, a), 1e-12);
  // Measured (shipped vocabulary, k = 10, L = 4): same view 0.52, other scene 0.11, other view
  // 0.15 (3.5-5x). Margin: same > 2.5x either.
  EXPECT_GT(same, 2.5 * other_scene) << same << " vs " << other_scene;
  EXPECT_GT(same, 2.5 * other_view) << same << " vs " << other_view;
  // Unrelated images share few words in absolute terms too (a vocabulary with too few or too
  // coarse words scores every pair alike; one word scores 1.0). Deterministic (shipped vocabulary,
  // generated images): 0.11 on every run; bound at twice that.
  EXPECT_LT(other_scene, 0.22) << other_scene;
  std::printf("score same view %.3f, other scene %.3f, other view %.3f\n", same, other_scene,
              other_view);
}

TEST_F(VocabularyTest, DirectIndexCoversEveryFeatureOnce) {
  const Vocabulary& v = *vocabulary_;  // k = 8: at most 64 level-2 nodes
  const auto descriptors = QueryImage(7, 30, 0.0);
  BowVector bow;
  FeatureVector features;
  v.Transform(descriptors, &bow, &features, 2);
  std::vector<int> seen(descriptors.size(), 0);
  for (const auto& [node, indices] : features) {
    EXPECT_GT(node, 0u);  // not the root
    EXPECT_TRUE(std::is_sorted(indices.begin(), indices.end()));
    for (int i : indices) {
      seen[i]++;
      NodeId expected = 0;
      v.Transform(descriptors[i], 2, &expected);
      EXPECT_EQ(expected, node);
    }
  }
  for (int s : seen) EXPECT_EQ(s, 1);
  // At most k^2 level-2 nodes, and ~1000 features spread over many of them.
  EXPECT_LE(features.size(), 64u);
  EXPECT_GT(features.size(), 16u);
}

TEST_F(VocabularyTest, SaveLoadRoundTrip) {
  const std::string path = testing::MakeTempDir("vocabulary") + "/voc.dygvoc";
  vocabulary_->Save(path);
  const Vocabulary loaded = Vocabulary::Load(path);
  EXPECT_EQ(loaded.Checksum(), vocabulary_->Checksum());
  EXPECT_EQ(loaded.NumWords(), vocabulary_->NumWords());
  const auto descriptors = QueryImage(9, 5, 0.0);
  BowVector a, b;
  FeatureVector fa, fb;
  vocabulary_->Transform(descriptors, &a, &fa);
  loaded.Transform(descriptors, &b, &fb);
  EXPECT_EQ(a, b);
  EXPECT_EQ(fa, fb);
}

std::string ErrorOf(const std::string& path) {
  try {
    Vocabulary::Load(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST_F(VocabularyTest, MissingOrCorruptFileIsAClearError) {
  const std::string dir = testing::MakeTempDir("vocabulary_bad");
  const std::string missing = dir + "/none.dygvoc";

  EXPECT_NE(ErrorOf(missing).find(missing), std::string::npos);
  EXPECT_NE(ErrorOf(missing).find("cannot open"), std::string::npos);

  const std::string good = dir + "/good.dygvoc";
  vocabulary_->Save(good);
  std::ifstream in(good, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto write = [&](const std::string& name, const std::string& content) {
    const std::string p = dir + "/" + name;
    std::ofstream(p, std::ios::binary) << content;
    return p;
  };
  std::string flipped = bytes;
  flipped[bytes.size() / 2] ^= 0x10;
  const std::string corrupt = write("corrupt.dygvoc", flipped);
  EXPECT_NE(ErrorOf(corrupt).find(corrupt), std::string::npos);
  EXPECT_NE(ErrorOf(corrupt).find("checksum"), std::string::npos);
  const std::string truncated = write("truncated.dygvoc", bytes.substr(0, bytes.size() - 100));
  EXPECT_NE(ErrorOf(truncated).find("truncated"), std::string::npos);
  const std::string foreign = write("foreign.dygvoc", "ORBvoc text vocabulary\n" + bytes);
  EXPECT_NE(ErrorOf(foreign).find("bad magic"), std::string::npos);
  const std::string empty = write("empty.dygvoc", "");
  EXPECT_NE(ErrorOf(empty).find("too short"), std::string::npos);
}

}  // namespace
}  // namespace dygslam
