// BoxPropagator on generated feature tracks: a box over a moving patch follows the patch; a box
// without enough matches keeps its last velocity; shift_boxes = false carries boxes unchanged.
#include "core/dynamic/detection_propagation.h"

#include <gtest/gtest.h>

#include <random>

namespace dygslam {
namespace {

// Features of two consecutive frames: a static background grid and a patch (the "person") of
// features that moved by `motion`; feature i of the current frame matches feature i of the previous.
struct TwoFrames {
  std::vector<cv::KeyPoint> previous, current;
  FilterResult result;
};

TwoFrames MakeFrames(const cv::Rect2f& patch, cv::Point2f motion, unsigned seed) {
  TwoFrames f;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> jitter(-0.3f, 0.3f);
  auto add = [&](cv::Point2f p, cv::Point2f d) {
    f.previous.emplace_back(p, 7.f);
    f.current.emplace_back(p + d + cv::Point2f(jitter(rng), jitter(rng)), 7.f);
    FeatureStatus s;
    s.prev_match = static_cast<int>(f.previous.size()) - 1;
    f.result.features.push_back(s);
  };
  for (float y = 10; y < 480; y += 20)
    for (float x = 10; x < 640; x += 20)
      if (!patch.contains({x, y})) add({x, y}, {0.f, 0.f});
  for (float y = patch.y + 4; y < patch.y + patch.height; y += 8)
    for (float x = patch.x + 4; x < patch.x + patch.width; x += 8) add({x, y}, motion);
  return f;
}

Detection Box(const cv::Rect2f& r) {
  Detection d;
  d.box = r;
  d.label = "person";
  d.score = 0.9f;
  return d;
}

TEST(BoxPropagation, MedianDisplacementIsThePatchMotionWhenThePatchFillsTheBox) {
  const cv::Rect2f patch(200, 100, 120, 260);
  const TwoFrames f = MakeFrames(patch, {6.f, -2.f}, 1);
  int count = 0;
  // The box where the patch is now (previous position + motion), slightly inside it.
  const cv::Rect2f box(patch.x + 6 + 8, patch.y - 2 + 8, patch.width - 16, patch.height - 16);
  const cv::Point2f d = MedianDisplacementInBox(box, f.previous, f.current, f.result.features, &count);
  EXPECT_GT(count, 300);
  EXPECT_NEAR(d.x, 6.f, 0.3f);
  EXPECT_NEAR(d.y, -2.f, 0.3f);
  // A box over the background only: no motion.
  const cv::Point2f bg = MedianDisplacementInBox(cv::Rect2f(400, 50, 150, 150), f.previous,
                                                 f.current, f.result.features, &count);
  EXPECT_GT(count, 40);
  EXPECT_NEAR(bg.x, 0.f, 0.3f);
  EXPECT_NEAR(bg.y, 0.f, 0.3f);
}

TEST(BoxPropagation, CarriedBoxFollowsItsContentOverTheGap) {
  const cv::Point2f motion(5.f, 1.f);
  cv::Rect2f patch(100, 120, 100, 240);
  BoxPropagator boxes;
  // Frame 0: detected box on the patch; the filter's matches of frame 0 -> previous give v.
  boxes.SetDetections({Box(patch)});
  TwoFrames f = MakeFrames(cv::Rect2f(patch.x - motion.x, patch.y - motion.y, patch.width,
                                      patch.height),
                           motion, 2);
  boxes.Observe(f.previous, f.current, f.result);
  // Frames 1..3 without the detector: the box moves with the patch.
  for (int k = 1; k <= 3; ++k) {
    const std::vector<Detection> carried = boxes.Predict();
    ASSERT_EQ(carried.size(), 1u);
    const cv::Rect2f expected(patch.x + k * motion.x, patch.y + k * motion.y, patch.width,
                              patch.height);
    const float iou = (carried[0].box & expected).area() / (carried[0].box | expected).area();
    EXPECT_GT(iou, 0.97f) << "frame " << k;
    f = MakeFrames(cv::Rect2f(patch.x + (k - 1) * motion.x, patch.y + (k - 1) * motion.y,
                              patch.width, patch.height),
                   motion, 3 + k);
    boxes.Observe(f.previous, f.current, f.result);
  }
}

TEST(BoxPropagation, UnshiftedOrUnmatchedBoxesStayPut) {
  const cv::Rect2f patch(300, 100, 100, 200);
  const TwoFrames f = MakeFrames(patch, {8.f, 0.f}, 5);
  BoxPropagationOptions options;
  options.shift_boxes = false;
  BoxPropagator unshifted(options);
  unshifted.SetDetections({Box(patch)});
  unshifted.Observe(f.previous, f.current, f.result);
  EXPECT_EQ(unshifted.Predict()[0].box, patch);

  // No feature in the box: the velocity stays zero.
  options.shift_boxes = true;
  options.min_matches = 4;
  BoxPropagator empty(options);
  const cv::Rect2f nowhere(1000, 1000, 50, 50);
  empty.SetDetections({Box(nowhere)});
  empty.Observe(f.previous, f.current, f.result);
  EXPECT_EQ(empty.Predict()[0].box, nowhere);
  EXPECT_THROW(BoxPropagator(BoxPropagationOptions{0, true}), InvalidOptions);
}

}  // namespace
}  // namespace dygslam
