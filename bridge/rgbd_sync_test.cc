#include "bridge/rgbd_sync.h"

#include <gtest/gtest.h>

#include "core/base/error.h"

namespace dygslam::ros2 {
namespace {

StampedImage At(int64_t ms, int tag = 0) {
  StampedImage s;
  s.stamp = Timestamp::FromNanoseconds(ms * 1000000);
  s.image = cv::Mat(1, 1, CV_8UC1, cv::Scalar(tag));
  return s;
}
// A depth image tagged with its stamp in ms (< 256), so the frame shows which depth it got.
StampedImage DepthAt(int64_t ms) { return At(ms, static_cast<int>(ms)); }
int64_t Ms(const RgbdFrame& f) { return f.stamp.nanoseconds() / 1000000; }
int DepthTag(const RgbdFrame& f) { return f.depth.at<uint8_t>(0, 0); }

TEST(RgbdSync, ExactStampsPairImmediatelyInEitherOrder) {
  RgbdSynchronizer sync({0.02, 8});
  EXPECT_TRUE(sync.AddColor(At(100)).empty());
  auto pairs = sync.AddDepth(DepthAt(100));
  ASSERT_EQ(pairs.size(), 1u);
  EXPECT_EQ(Ms(pairs[0]), 100);
  EXPECT_EQ(DepthTag(pairs[0]), 100);
  EXPECT_TRUE(sync.AddDepth(DepthAt(133)).empty());
  pairs = sync.AddColor(At(133));
  ASSERT_EQ(pairs.size(), 1u);
  EXPECT_EQ(sync.stats().pairs, 2u);
  EXPECT_EQ(sync.pending_color() + sync.pending_depth(), 0u);
}

TEST(RgbdSync, NearestDepthWithinToleranceOnceFinal) {
  RgbdSynchronizer sync({0.02, 8});
  sync.AddDepth(DepthAt(95));
  // Depth 95 is older than colour 100: a later depth may be closer, so wait.
  EXPECT_TRUE(sync.AddColor(At(100)).empty());
  // 103 is closer (3 ms) than 95 (5 ms) and after the colour: final.
  auto pairs = sync.AddDepth(DepthAt(103));
  ASSERT_EQ(pairs.size(), 1u);
  EXPECT_EQ(DepthTag(pairs[0]), 103);
  EXPECT_EQ(sync.stats().dropped_depth, 1u);  // 95 can no longer serve a later colour better
}

TEST(RgbdSync, ColourWithoutPartnerInToleranceIsDropped) {
  RgbdSynchronizer sync({0.01, 8});
  sync.AddColor(At(100));
  sync.AddColor(At(133));
  auto pairs = sync.AddDepth(DepthAt(131));  // 100 is 31 ms away (dropped), 133 pairs with 131? no:
  // 131 is older than 133 and not exact, so 133 waits for a later depth.
  EXPECT_TRUE(pairs.empty());
  EXPECT_EQ(sync.stats().dropped_color, 1u);
  pairs = sync.AddDepth(DepthAt(166));  // 131 (2 ms) beats 166 (33 ms)
  ASSERT_EQ(pairs.size(), 1u);
  EXPECT_EQ(Ms(pairs[0]), 133);
  EXPECT_EQ(DepthTag(pairs[0]), 131);
}

TEST(RgbdSync, OutOfOrderAndOverflowAreDroppedAndCounted) {
  RgbdSynchronizer sync({0.02, 3});
  sync.AddColor(At(100));
  EXPECT_TRUE(sync.AddColor(At(100)).empty());  // duplicate stamp
  EXPECT_TRUE(sync.AddColor(At(90)).empty());   // going back in time
  EXPECT_EQ(sync.stats().dropped_color, 2u);
  for (int i = 1; i <= 4; ++i) sync.AddColor(At(100 + 33 * i));  // no depth stream at all
  EXPECT_EQ(sync.pending_color(), 3u);
  EXPECT_EQ(sync.stats().dropped_color, 4u);
  // Depth arrives: the queued colours pair in order.
  auto pairs = sync.AddDepth(DepthAt(199));
  ASSERT_EQ(pairs.size(), 1u);
  EXPECT_EQ(Ms(pairs[0]), 199);
}

TEST(RgbdSync, InvalidOptions) {
  EXPECT_THROW(RgbdSynchronizer({-1.0, 8}), InvalidOptions);
  EXPECT_THROW(RgbdSynchronizer({0.02, 0}), InvalidOptions);
}

}  // namespace
}  // namespace dygslam::ros2
