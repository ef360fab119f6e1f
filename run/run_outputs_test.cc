#include "run/run_outputs.h"

#include <gtest/gtest.h>

#include <sstream>
#include <string>
#include <vector>

namespace dygslam {
namespace {

std::vector<std::string> Split(std::string line) {
  if (!line.empty() && line.back() == '\n') line.pop_back();
  std::vector<std::string> fields;
  std::stringstream in(line);
  std::string f;
  while (std::getline(in, f, ',')) fields.push_back(f);
  return fields;
}

TEST(RunOutputs, FramesCsvRowMatchesTheHeader) {
  FrameResult r;
  r.stamp = Timestamp::FromNanoseconds(1548266470123456789);
  r.state = TrackingState::kFallback;
  r.is_keyframe = true;
  r.num_features = 1000;
  r.num_dynamic = 37;
  r.num_tracked = 412;
  r.times.orb_extraction_ms = 6.25;
  r.times.detection_ms = 11.5;
  r.times.matching_ms = 0.75;
  r.times.probability_ms = 1.125;
  r.times.tracking_ms = 4.5;
  r.times.total_ms = 14.0625;
  const std::vector<std::string> header = Split(FramesCsvHeader());
  const std::vector<std::string> row = Split(FramesCsvRow(FrameRowFromResult(r)));
  ASSERT_EQ(header.size(), 12u);
  ASSERT_EQ(row.size(), header.size());
  EXPECT_EQ(header[0], "stamp");
  EXPECT_EQ(row[0], r.stamp.ToString());
  EXPECT_EQ(row[1], ToString(TrackingState::kFallback));
  EXPECT_EQ(row[2], "1");
  EXPECT_EQ(row[3], "1000");
  EXPECT_EQ(row[4], "37");
  EXPECT_EQ(row[5], "412");
  EXPECT_EQ(row[6], "6.250");
  EXPECT_EQ(row[7], "11.500");
  EXPECT_EQ(row[10], "4.500");
  EXPECT_EQ(row[11], "14.062");  // 3 decimals, round half to even of the binary value
}

TEST(RunOutputs, FrameRowKeepsEveryField) {
  FrameResult r;
  r.stamp = Timestamp::FromNanoseconds(42);
  r.state = TrackingState::kLost;
  r.num_features = 3;
  r.times.tracking_ms = 2;
  const FrameRow row = FrameRowFromResult(r);
  EXPECT_EQ(row.stamp, r.stamp);
  EXPECT_EQ(row.state, TrackingState::kLost);
  EXPECT_FALSE(row.is_keyframe);
  EXPECT_EQ(row.num_features, 3);
  EXPECT_EQ(row.times.tracking_ms, 2);
}

}  // namespace
}  // namespace dygslam
