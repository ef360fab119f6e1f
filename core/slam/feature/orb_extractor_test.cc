#include "core/slam/feature/orb_extractor.h"

#include <gtest/gtest.h>

#include <iostream>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <random>

namespace dygslam {
namespace {

// A textured test image: random rectangles of random intensity over noise.
cv::Mat TexturedImage(int seed, int width = 640, int height = 480) {
  std::mt19937 rng(seed);
  cv::Mat img(height, width, CV_8UC1);
  cv::randu(img, 60, 120);
  cv::GaussianBlur(img, img, cv::Size(5, 5), 2);
  std::uniform_int_distribution<int> x(0, width - 1), y(0, height - 1), s(5, 40), c(0, 255);
  for (int i = 0; i < 600; ++i) {
    cv::rectangle(img, cv::Rect(x(rng), y(rng), s(rng), s(rng)), cv::Scalar(c(rng)), cv::FILLED);
  }
  return img;
}

TEST(OrbExtractor, FeatureCountAndSpread) {
  OrbExtractorOptions options;
  OrbExtractor extractor(options);
  const cv::Mat img = TexturedImage(1);
  const OrbFeatures f = extractor.Extract(img);
  ASSERT_EQ(f.keypoints.size(), f.descriptors.size());
  EXPECT_GE(f.keypoints.size(), 900u);
  EXPECT_LE(f.keypoints.size(), 1000u);
  // Spread: level-0 features cover most cells of an 8x6 grid.
  std::vector<int> cells(48, 0);
  std::vector<int> per_level(options.num_levels, 0);
  for (const auto& kp : f.keypoints) {
    per_level[kp.octave]++;
    cells[std::min(5, int(kp.pt.y / 80)) * 8 + std::min(7, int(kp.pt.x / 80))]++;
  }
  int covered = 0;
  for (int c : cells) covered += c > 0;
  EXPECT_GE(covered, 44);
  // More features on finer levels (geometric allocation).
  EXPECT_GT(per_level[0], per_level[3]);
  EXPECT_GT(per_level[3], 0);
}

TEST(OrbExtractor, DeterministicAndMaskRespected) {
  OrbExtractor extractor(OrbExtractorOptions{});
  const cv::Mat img = TexturedImage(2);
  const OrbFeatures a = extractor.Extract(img), b = extractor.Extract(img);
  ASSERT_EQ(a.keypoints.size(), b.keypoints.size());
  for (size_t i = 0; i < a.keypoints.size(); ++i) {
    EXPECT_EQ(a.keypoints[i].pt, b.keypoints[i].pt);
    EXPECT_EQ(a.descriptors[i], b.descriptors[i]);
  }
  cv::Mat mask = cv::Mat::zeros(img.size(), CV_8UC1);
  mask(cv::Rect(0, 0, 320, 480)).setTo(255);
  const OrbFeatures m = extractor.Extract(img, mask);
  for (const auto& kp : m.keypoints) EXPECT_GE(kp.pt.x, 318.0f);
}

// A cache filled by one extraction gives a second extraction on the same image (another mask and
// budget, as System's top-up) exactly what an extraction without cache gives; another image
// refills it.
TEST(OrbExtractor, CacheReuseGivesIdenticalFeatures) {
  OrbExtractor extractor(OrbExtractorOptions{});
  const cv::Mat img = TexturedImage(4), other = TexturedImage(5);
  cv::Mat mask = cv::Mat::zeros(img.size(), CV_8UC1);
  mask(cv::Rect(100, 50, 300, 300)).setTo(255);
  auto expect_same = [](const OrbFeatures& a, const OrbFeatures& b) {
    ASSERT_EQ(a.keypoints.size(), b.keypoints.size());
    for (size_t i = 0; i < a.keypoints.size(); ++i) {
      EXPECT_EQ(a.keypoints[i].pt, b.keypoints[i].pt);
      EXPECT_EQ(a.keypoints[i].octave, b.keypoints[i].octave);
      EXPECT_FLOAT_EQ(a.keypoints[i].angle, b.keypoints[i].angle);
      EXPECT_EQ(a.descriptors[i], b.descriptors[i]);
    }
  };
  OrbExtractionCache cache;
  EXPECT_FALSE(cache.IsFor(img));
  expect_same(extractor.Extract(img, cv::Mat(), -1, &cache), extractor.Extract(img));
  EXPECT_TRUE(cache.IsFor(img));
  const OrbFeatures top_up = extractor.Extract(img, mask, 300, &cache);
  expect_same(top_up, extractor.Extract(img, mask, 300));
  EXPECT_GT(top_up.keypoints.size(), 200u);
  for (const auto& kp : top_up.keypoints) {
    EXPECT_FALSE(kp.pt.x >= 101 && kp.pt.x < 399 && kp.pt.y >= 51 && kp.pt.y < 349) << kp.pt;
  }
  expect_same(extractor.Extract(other, cv::Mat(), -1, &cache), extractor.Extract(other));
  EXPECT_TRUE(cache.IsFor(other));
  EXPECT_FALSE(cache.IsFor(img));
}

// A skip predicate drops exactly the features it names, seen as the output reports them (level-0
// position, level as octave), and leaves the others' descriptors as they were.
TEST(OrbExtractor, SkippedFeaturesAreDroppedAndTheRestUnchanged) {
  OrbExtractor extractor(OrbExtractorOptions{});
  const cv::Mat img = TexturedImage(6);
  const OrbFeatures all = extractor.Extract(img);
  const auto skip = [](const cv::KeyPoint& kp) { return kp.pt.x < 320.f || kp.octave == 2; };
  const OrbFeatures kept = extractor.Extract(img, cv::Mat(), -1, nullptr, skip);
  std::vector<size_t> expected;
  for (size_t i = 0; i < all.keypoints.size(); ++i)
    if (!skip(all.keypoints[i])) expected.push_back(i);
  ASSERT_GT(expected.size(), 200u);
  ASSERT_LT(expected.size(), all.keypoints.size() / 2 + 100);
  ASSERT_EQ(kept.keypoints.size(), expected.size());
  for (size_t k = 0; k < expected.size(); ++k) {
    EXPECT_EQ(kept.keypoints[k].pt, all.keypoints[expected[k]].pt);
    EXPECT_EQ(kept.keypoints[k].octave, all.keypoints[expected[k]].octave);
    EXPECT_EQ(kept.descriptors[k], all.descriptors[expected[k]]);
  }
}

// Steered descriptors are rotation invariant: for keypoints re-detected at the rotated position
// (same octave), the nearest neighbour among all descriptors of the rotated image is the true
// partner, and its distance is small.
TEST(OrbExtractor, DescriptorsAreRotationInvariant) {
  OrbExtractor extractor(OrbExtractorOptions{});
  const cv::Mat img = TexturedImage(3, 800, 600);
  for (double angle : {20.0, 45.0, 90.0}) {
    const cv::Mat rot = cv::getRotationMatrix2D(cv::Point2f(400, 300), angle, 1.0);
    cv::Mat warped;
    cv::warpAffine(img, warped, rot, img.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
    const OrbFeatures a = extractor.Extract(img), b = extractor.Extract(warped);
    int pairs = 0, nn_correct = 0;
    for (size_t i = 0; i < a.keypoints.size(); ++i) {
      const cv::Point2f p = a.keypoints[i].pt;
      if (cv::norm(p - cv::Point2f(400, 300)) > 200) continue;
      const cv::Point2f e(
          float(rot.at<double>(0, 0) * p.x + rot.at<double>(0, 1) * p.y + rot.at<double>(0, 2)),
          float(rot.at<double>(1, 0) * p.x + rot.at<double>(1, 1) * p.y + rot.at<double>(1, 2)));
      int partner = -1;
      for (size_t j = 0; j < b.keypoints.size(); ++j) {
        if (b.keypoints[j].octave == a.keypoints[i].octave &&
            cv::norm(b.keypoints[j].pt - e) < 1.5) {
          partner = static_cast<int>(j);
          break;
        }
      }
      if (partner < 0) continue;
      ++pairs;
      int best = 257, best_j = -1;
      for (size_t j = 0; j < b.keypoints.size(); ++j) {
        const int d = HammingDistance(a.descriptors[i], b.descriptors[j]);
        if (d < best) {
          best = d;
          best_j = static_cast<int>(j);
        }
      }
      if (best_j == partner) ++nn_correct;
    }
    std::cout << "angle " << angle << ": " << nn_correct << "/" << pairs
              << " nearest neighbours correct\n";
    ASSERT_GT(pairs, 40);
    EXPECT_GT(double(nn_correct) / pairs, 0.85);
  }
}

}  // namespace
}  // namespace dygslam
