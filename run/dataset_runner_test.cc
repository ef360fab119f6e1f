// The dataset -> System loop on the first frames of bonn_crowd_part (filter none: no detector
// needed, a few seconds).
#include "run/dataset_runner.h"

#include <gtest/gtest.h>

#include <vector>

#include "core/base/error.h"
#include "run/run_settings.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {

constexpr size_t kFrames = 12;

RunConfiguration Configuration(const std::string& filter) {
  RunSettingsRequest request;
  request.settings_path = std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/bonn.yaml";
  request.read.print_warnings = false;
  request.filter = filter;
  request.deterministic = true;
  return LoadRunConfiguration(request);
}

DatasetRunOptions RangeOptions(const RunConfiguration& c, size_t first, size_t last) {
  DatasetRunOptions o;
  o.first_entry = first;
  o.last_entry = last;
  o.image_width = c.system.camera.width;
  o.image_height = c.system.camera.height;
  return o;
}

TEST(DatasetRunner, FeedsEveryEntryOfTheRangeInOrder) {
  DYGSLAM_REQUIRE_DATASET(dir, "bonn_crowd_part");
  const RgbdDataset dataset = RgbdDataset::Open(dir);
  const RunConfiguration c = Configuration("none");
  System system(c.system);
  std::vector<size_t> entries;
  std::vector<Timestamp> stamps;
  const DatasetRunSummary s = RunDatasetFrames(dataset, system, RangeOptions(c, 3, 3 + kFrames),
                                               [&](size_t entry, const FrameResult& r) {
                                                 entries.push_back(entry);
                                                 stamps.push_back(r.stamp);
                                               });
  system.Shutdown();
  EXPECT_FALSE(s.interrupted);
  EXPECT_EQ(s.processed + s.skipped, kFrames);
  ASSERT_EQ(entries.size(), s.processed);
  for (size_t i = 0; i < entries.size(); ++i) {
    const auto index = dataset.FrameForRgbEntry(entries[i]);
    ASSERT_TRUE(index.has_value());
    EXPECT_EQ(stamps[i], dataset.frame(*index).rgb_stamp);
    if (i > 0) EXPECT_GT(entries[i], entries[i - 1]);
  }
  // The first frame initialises the map; the next ones track against it.
  EXPECT_EQ(system.Trajectory().size(), s.processed - s.lost);
}

TEST(DatasetRunner, StopFlagEndsTheRunBeforeTheNextFrame) {
  DYGSLAM_REQUIRE_DATASET(dir, "bonn_crowd_part");
  const RgbdDataset dataset = RgbdDataset::Open(dir);
  const RunConfiguration c = Configuration("none");
  System system(c.system);
  DatasetRunOptions o = RangeOptions(c, 0, kFrames);
  size_t fed = 0;
  o.stop = [&] { return fed >= 4; };
  const DatasetRunSummary s =
      RunDatasetFrames(dataset, system, o, [&](size_t, const FrameResult&) { ++fed; });
  system.Shutdown();
  EXPECT_TRUE(s.interrupted);
  EXPECT_EQ(s.processed, 4u);
  EXPECT_EQ(fed, 4u);
}

TEST(DatasetRunner, BoxesFromAFileAndStampOffset) {
  DYGSLAM_REQUIRE_DATASET(dir, "bonn_crowd_part");
  const RgbdDataset dataset = RgbdDataset::Open(dir);
  const RunConfiguration c = Configuration("boxes");
  System system(c.system);
  DatasetRunOptions o = RangeOptions(c, 0, 4);
  o.stamp_offset_ns = 1000000000;  // 1 s later
  // One box (left third of the image) at every shifted stamp: the detector never runs.
  std::map<Timestamp, std::vector<Detection>> boxes;
  for (size_t k = 0; k < 4; ++k) {
    const auto index = dataset.FrameForRgbEntry(k);
    if (!index) continue;
    Detection d;
    d.box = cv::Rect2f(0, 0, c.system.camera.width / 3.f, c.system.camera.height);
    d.label = "person";
    d.score = 0.9f;
    boxes[Timestamp::FromNanoseconds(dataset.frame(*index).rgb_stamp.nanoseconds() +
                                     o.stamp_offset_ns)] = {d};
  }
  o.detections = &boxes;
  size_t with_boxes = 0;
  const DatasetRunSummary s =
      RunDatasetFrames(dataset, system, o, [&](size_t entry, const FrameResult& r) {
        const auto index = dataset.FrameForRgbEntry(entry);
        EXPECT_EQ(r.stamp.nanoseconds(),
                  dataset.frame(*index).rgb_stamp.nanoseconds() + o.stamp_offset_ns);
        if (r.detections_used) ++with_boxes;
      });
  system.Shutdown();
  EXPECT_GT(s.processed, 0u);
  EXPECT_EQ(with_boxes, s.processed);
}

TEST(DatasetRunner, RangeBeyondTheDatasetIsAClearError) {
  DYGSLAM_REQUIRE_DATASET(dir, "bonn_crowd_part");
  const RgbdDataset dataset = RgbdDataset::Open(dir);
  const RunConfiguration c = Configuration("none");
  System system(c.system);
  EXPECT_THROW(RunDatasetFrames(dataset, system, RangeOptions(c, 0, dataset.num_rgb_entries() + 1)),
               InvalidOptions);
  DatasetRunOptions reversed = RangeOptions(c, 5, 2);
  EXPECT_THROW(RunDatasetFrames(dataset, system, reversed), InvalidOptions);
  system.Shutdown();
}

}  // namespace
}  // namespace dygslam
