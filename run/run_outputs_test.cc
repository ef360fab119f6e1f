#include "run/run_outputs.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/io/trajectory_io.h"

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
  ASSERT_EQ(header.size(), 15u);
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

std::string WriteText(const std::string& name, const std::string& text) {
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("run_outputs_test_" + std::to_string(::getpid()) + "_" + name))
                               .string();
  std::ofstream(path) << text;
  return path;
}

// What the run and the benchmark write, they read back: every field, every stage column.
TEST(RunOutputs, FramesCsvReadsBackWhatWasWritten) {
  FrameRow a;
  a.stamp = Timestamp::FromNanoseconds(1548266470123456789);
  a.state = TrackingState::kRelocalized;
  a.is_keyframe = true;
  a.num_features = 1000;
  a.num_dynamic = 12;
  a.num_tracked = 300;
  a.times.orb_extraction_ms = 6.25;
  a.times.detection_wait_ms = 1.5;
  a.times.local_mapping_ms = 9.75;
  a.times.top_up_ms = 0.5;
  a.times.total_ms = 20;
  FrameRow b;
  b.stamp = Timestamp::FromNanoseconds(1548266470156789012);
  b.state = TrackingState::kLost;
  const std::string path =
      WriteText("ok.csv", FramesCsvHeader() + FramesCsvRow(a) + FramesCsvRow(b));
  const std::vector<FrameRow> rows = ReadFramesCsv(path);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].stamp, a.stamp);
  EXPECT_EQ(rows[0].state, TrackingState::kRelocalized);
  EXPECT_TRUE(rows[0].is_keyframe);
  EXPECT_EQ(rows[0].num_features, 1000);
  EXPECT_EQ(rows[0].num_dynamic, 12);
  EXPECT_EQ(rows[0].num_tracked, 300);
  EXPECT_EQ(rows[0].times.orb_extraction_ms, 6.25);
  EXPECT_EQ(rows[0].times.detection_wait_ms, 1.5);
  EXPECT_EQ(rows[0].times.local_mapping_ms, 9.75);
  EXPECT_EQ(rows[0].times.top_up_ms, 0.5);
  EXPECT_EQ(rows[0].times.total_ms, 20);
  EXPECT_EQ(rows[1].state, TrackingState::kLost);
  EXPECT_FALSE(rows[1].is_keyframe);
  std::filesystem::remove(path);
}

// A file of the earlier 12-column layout reads with the missing stage columns at 0; a broken one
// is named with its line.
TEST(RunOutputs, FramesCsvReadsByColumnNameAndNamesBadLines) {
  const std::string old =
      WriteText("old.csv",
                "stamp,state,keyframe,features,dynamic,tracked,orb_ms,detection_ms,matching_ms,"
                "probability_ms,tracking_ms,total_ms\n1.5,ok,0,900,3,250,5,6,7,8,9,30\n");
  const std::vector<FrameRow> rows = ReadFramesCsv(old);
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].times.total_ms, 30);
  EXPECT_EQ(rows[0].times.top_up_ms, 0);
  auto error_of = [](const std::string& path) {
    try {
      ReadFramesCsv(path);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  const std::string state =
      WriteText("state.csv", FramesCsvHeader() + "1.5,flying,0,0,0,0,0,0,0,0,0,0,0,0,0\n");
  EXPECT_NE(error_of(state).find(":2: unknown state 'flying'"), std::string::npos)
      << error_of(state);
  const std::string short_row = WriteText("short.csv", FramesCsvHeader() + "1.5,ok,0\n");
  EXPECT_NE(error_of(short_row).find(":2: expected 15 columns"), std::string::npos)
      << error_of(short_row);
  const std::string number =
      WriteText("number.csv", FramesCsvHeader() + "1.5,ok,0,0,0,0,0,0,0,0,0,nan,0,0,0\n");
  EXPECT_NE(error_of(number).find(":2: total_ms: not a number"), std::string::npos)
      << error_of(number);
  const std::string headerless = WriteText("headerless.csv", "1.5,ok,0\n");
  EXPECT_NE(error_of(headerless).find("not a frames.csv"), std::string::npos);
  for (const std::string& p : {old, state, short_row, number, headerless})
    std::filesystem::remove(p);
}

std::filesystem::path MakeRunFolder(const std::string& name) {
  std::string pattern =
      (std::filesystem::temp_directory_path() / ("run_record_" + name + "_XXXXXX"));
  EXPECT_NE(::mkdtemp(pattern.data()), nullptr);
  return pattern;
}

RunRecord TwoFrameRecord() {
  RunRecord record;
  FrameRow row;
  row.state = TrackingState::kOk;
  row.stamp = Timestamp::FromNanoseconds(1000000000);
  record.rows = std::vector<FrameRow>{row};
  row.stamp = Timestamp::FromNanoseconds(1033333333);
  record.rows->push_back(row);
  for (const FrameRow& r : *record.rows) {
    StampedPose p;
    p.stamp = r.stamp;
    p.world_from_cam.translation = Eigen::Vector3d(0.1 * record.trajectory.size(), 0, 0);
    record.trajectory.push_back(p);
  }
  record.online = record.trajectory;
  record.keyframes = std::vector<StampedPose>{record.trajectory.front()};
  return record;
}

// Every way of running hands its results over as one record: each part set is written, a part
// left unset is not, and the files read back as they were given.
TEST(RunRecord, WritesEachPartItHoldsAndReadsBack) {
  const std::filesystem::path dir = MakeRunFolder("parts");
  RunOutputs outputs(dir,
                     {"trajectory.txt", "trajectory_online.txt", "keyframes.txt", "frames.csv"});
  RunRecord record = TwoFrameRecord();
  record.online.reset();
  EXPECT_TRUE(WriteRunRecord(outputs, record));
  EXPECT_TRUE(outputs.failures().empty());
  EXPECT_EQ(ReadFramesCsv(outputs.PathOf("frames.csv")).size(), 2u);
  const std::vector<StampedPose> trajectory = ReadTumTrajectory(outputs.PathOf("trajectory.txt"));
  ASSERT_EQ(trajectory.size(), 2u);
  EXPECT_NEAR(trajectory[1].world_from_cam.translation.x(), 0.1, 1e-9);
  EXPECT_EQ(ReadTumTrajectory(outputs.PathOf("keyframes.txt")).size(), 1u);
  EXPECT_FALSE(std::filesystem::exists(outputs.PathOf("trajectory_online.txt")));
  EXPECT_EQ(outputs.FreshNames(),
            (std::vector<std::string>{"trajectory.txt", "keyframes.txt", "frames.csv"}));
  std::filesystem::remove_all(dir);
}

// A record without a frame (a run stopped before its first) keeps an earlier run's files; in an
// empty folder it writes the empty, loadable files.
TEST(RunRecord, ARecordWithoutAFrameKeepsAnEarlierRunsFiles) {
  const std::filesystem::path dir = MakeRunFolder("empty");
  {
    RunOutputs outputs(dir, {"trajectory.txt", "frames.csv"});
    EXPECT_TRUE(WriteRunRecord(outputs, TwoFrameRecord()));
  }
  RunRecord empty;
  empty.rows.emplace();
  RunOutputs again(dir, {"trajectory.txt", "frames.csv"});
  EXPECT_FALSE(WriteRunRecord(again, empty));
  EXPECT_EQ(ReadTumTrajectory(again.PathOf("trajectory.txt")).size(), 2u);
  EXPECT_EQ(ReadFramesCsv(again.PathOf("frames.csv")).size(), 2u);
  EXPECT_TRUE(again.FreshNames().empty());
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  RunOutputs fresh(dir, {"trajectory.txt", "frames.csv"});
  EXPECT_TRUE(WriteRunRecord(fresh, empty));
  EXPECT_TRUE(ReadTumTrajectory(fresh.PathOf("trajectory.txt")).empty());
  EXPECT_TRUE(ReadFramesCsv(fresh.PathOf("frames.csv")).empty());
  std::filesystem::remove_all(dir);
}

// A part that cannot be written (a folder in its place) is recorded under its name; the parts
// after it are still written.
TEST(RunRecord, AFailedPartDoesNotStopTheOthers) {
  const std::filesystem::path dir = MakeRunFolder("fail");
  std::filesystem::create_directories(dir / "frames.csv" / "occupied");
  RunOutputs outputs(dir,
                     {"trajectory.txt", "trajectory_online.txt", "keyframes.txt", "frames.csv"});
  EXPECT_TRUE(WriteRunRecord(outputs, TwoFrameRecord()));
  ASSERT_EQ(outputs.failures().size(), 1u);
  EXPECT_EQ(outputs.failures()[0].first, "frames.csv");
  EXPECT_EQ(ReadTumTrajectory(outputs.PathOf("trajectory.txt")).size(), 2u);
  EXPECT_EQ(ReadTumTrajectory(outputs.PathOf("trajectory_online.txt")).size(), 2u);
  EXPECT_EQ(ReadTumTrajectory(outputs.PathOf("keyframes.txt")).size(), 1u);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace dygslam
