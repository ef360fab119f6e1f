// RecorderCore without DDS: slam's CameraPose / Trajectory messages (made with slam's own
// conversion, CameraPoseToMsg) -> trajectory.txt, trajectory_online.txt, keyframes.txt and
// frames.csv as `dygslam run --direct` writes them (run/run_outputs.h).
#include "components/recorder_core.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "components/convert.h"
#include "components/slam_core.h"
#include "core/base/error.h"
#include "core/io/trajectory_io.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {

FrameResult Result(int k, TrackingState state, bool keyframe) {
  FrameResult r;
  r.stamp = Timestamp::FromNanoseconds(1'000'000'000LL + k * 33'000'000LL);
  r.state = state;
  if (HasPose(state)) {
    r.world_from_cam = Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.01 * k, 0, 0));
  }
  r.is_keyframe = keyframe;
  r.num_features = 1000 + k;
  r.num_dynamic = k;
  r.num_tracked = 300 + k;
  r.times.orb_extraction_ms = 5.5;
  r.times.total_ms = 20.25 + k;
  return r;
}

std::vector<FrameResult> SampleRun() {
  return {Result(0, TrackingState::kOk, true), Result(1, TrackingState::kOk, false),
          Result(2, TrackingState::kLost, false), Result(3, TrackingState::kOk, true)};
}

std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> lines;
  size_t begin = 0;
  while (begin < text.size()) {
    const size_t end = text.find('\n', begin);
    lines.push_back(text.substr(begin, end - begin));
    if (end == std::string::npos) break;
    begin = end + 1;
  }
  return lines;
}

// A run that ends before its first frame (stopped, or a component failed at start-up) leaves an
// earlier run's files as they were: no empty trajectory replaces a complete one.
TEST(RecorderCore, NoFrameLeavesAnEarlierRunsFilesAsTheyWere) {
  RecorderOptions options;
  options.output_dir = testing::MakeTempDir("recorder_core_empty") + "/out";
  {
    RecorderCore earlier(options);
    for (const FrameResult& r : SampleRun()) earlier.AddPose(CameraPoseToMsg(r, 0, false));
    ASSERT_FALSE(earlier.Write().empty());
  }
  const std::vector<StampedPose> before = ReadTumTrajectory(options.output_dir + "/trajectory.txt");
  ASSERT_EQ(before.size(), 3u);
  RecorderCore empty(options);
  EXPECT_EQ(empty.Write(), "");
  // Also when slam sent its (empty) final trajectory, as it does when stopped before a frame.
  RecorderCore empty_final(options);
  empty_final.SetTrajectory(TrajectoryToMsg({}, false));
  EXPECT_EQ(empty_final.Write(), "");
  EXPECT_EQ(ReadTumTrajectory(options.output_dir + "/trajectory.txt").size(), 3u);
  EXPECT_EQ(ReadTumTrajectory(options.output_dir + "/trajectory_online.txt").size(), 3u);
}

// OUTPUT/groundtruth.txt: the recorder's own copy from an earlier run is replaced like the other
// outputs (a second run with more frames into the same folder); a user's file of that name is
// kept.
TEST(RecorderCore, ReplacesItsOwnGroundTruthCopyAndKeepsAUsersFile) {
  RecorderOptions options;
  options.output_dir = testing::MakeTempDir("recorder_core_truth") + "/out";
  const std::string copy = options.output_dir + "/groundtruth.txt";
  auto run_with_truth = [&](int frames) {
    RecorderCore core(options);
    for (int k = 0; k < frames; ++k) {
      core.AddPose(CameraPoseToMsg(Result(k, TrackingState::kOk, k == 0), k, false));
      core.AddGroundTruth(
          GroundTruthToMsg({Result(k, TrackingState::kOk, false).stamp,
                            Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(k, 0, 0))},
                           k));
    }
    core.Write();
  };
  run_with_truth(2);
  ASSERT_EQ(ReadTumTrajectory(copy).size(), 2u);
  run_with_truth(4);
  EXPECT_EQ(ReadTumTrajectory(copy).size(), 4u) << "the earlier copy was kept";
  const std::string mine = "# my own ground truth\n1 0 0 0 0 0 0 1\n";
  std::ofstream(copy) << mine;
  run_with_truth(4);
  EXPECT_EQ(testing::ReadAll(copy), mine);
}

TEST(RecorderCore, WritesTheRunFilesFromOnlinePoses) {
  RecorderOptions options;
  options.output_dir = testing::MakeTempDir("recorder_core") + "/out";
  RecorderCore core(options);
  // Out of order and once twice (a re-sent sample): the files are sorted by stamp, unique.
  const std::vector<FrameResult> run = SampleRun();
  for (size_t i : {1, 0, 3, 2, 3}) core.AddPose(CameraPoseToMsg(run[i], i, false));
  EXPECT_EQ(core.num_online_poses(), 4u);  // 3 tracked, one twice
  EXPECT_EQ(core.num_lost(), 1u);
  EXPECT_FALSE(core.has_final_trajectory());
  const std::string trajectory = core.Write();
  EXPECT_EQ(trajectory, options.output_dir + "/trajectory.txt");

  const std::vector<StampedPose> online = ReadTumTrajectory(trajectory);
  ASSERT_EQ(online.size(), 3u);  // the lost frame has no pose
  EXPECT_EQ(online[0].stamp, run[0].stamp);
  EXPECT_EQ(online[2].stamp, run[3].stamp);
  EXPECT_NEAR(online[2].world_from_cam.translation.x(), 0.03, 1e-9);
  const std::vector<StampedPose> keyframes =
      ReadTumTrajectory(options.output_dir + "/keyframes.txt");
  ASSERT_EQ(keyframes.size(), 2u);
  EXPECT_EQ(keyframes[1].stamp, run[3].stamp);
  EXPECT_EQ(ReadTumTrajectory(options.output_dir + "/trajectory_online.txt").size(), 3u);
  EXPECT_FALSE(std::filesystem::exists(options.output_dir + "/groundtruth.txt"));

  // frames.csv: the rows `dygslam run --direct` writes for the same results, in stamp order.
  std::string expected = FramesCsvHeader();
  for (const FrameResult& r : run) expected += FramesCsvRow(FrameRowFromResult(r));
  const std::string csv = testing::ReadAll(options.output_dir + "/frames.csv");
  const std::vector<std::string> got_lines = Lines(csv), expected_lines = Lines(expected);
  ASSERT_EQ(got_lines.size(), expected_lines.size() + 1) << "the re-sent frame has two rows";
  EXPECT_EQ(got_lines[0], expected_lines[0]);
  EXPECT_EQ(got_lines[1], expected_lines[1]);
  EXPECT_EQ(got_lines.back(), expected_lines.back());
}

TEST(RecorderCore, FinalTrajectoriesReplaceTheOnlinePoses) {
  RecorderOptions options;
  options.output_dir = testing::MakeTempDir("recorder_core_final");
  RecorderCore core(options);
  const std::vector<FrameResult> run = SampleRun();
  for (size_t i = 0; i < run.size(); ++i) core.AddPose(CameraPoseToMsg(run[i], i, false));
  std::vector<StampedPose> refined;
  for (const FrameResult& r : run) {
    if (r.world_from_cam) {
      refined.push_back(
          {r.stamp, Rigid3d(Eigen::Quaterniond::Identity(),
                            r.world_from_cam->translation + Eigen::Vector3d(0, 1, 0))});
    }
  }
  core.SetTrajectory(TrajectoryToMsg(refined, false));
  core.SetTrajectory(TrajectoryToMsg({refined.front()}, true));
  EXPECT_TRUE(core.has_final_trajectory());
  EXPECT_TRUE(core.has_final_keyframes());
  core.Write();
  const std::vector<StampedPose> final_poses =
      ReadTumTrajectory(options.output_dir + "/trajectory.txt");
  ASSERT_EQ(final_poses.size(), refined.size());
  EXPECT_NEAR(final_poses[0].world_from_cam.translation.y(), 1.0, 1e-9);
  EXPECT_EQ(ReadTumTrajectory(options.output_dir + "/keyframes.txt").size(), 1u);
  // The online poses stay as published.
  const std::vector<StampedPose> online =
      ReadTumTrajectory(options.output_dir + "/trajectory_online.txt");
  ASSERT_EQ(online.size(), refined.size());
  EXPECT_NEAR(online[0].world_from_cam.translation.y(), 0.0, 1e-9);
}

TEST(RecorderCore, RejectsABadTrackingStateByField) {
  RecorderOptions options;
  options.output_dir = testing::MakeTempDir("recorder_core_bad");
  RecorderCore core(options);
  msg::CameraPose pose = CameraPoseToMsg(SampleRun()[0], 0, false);
  pose.tracking_state(17);
  try {
    core.AddPose(pose);
    FAIL() << "tracking_state 17 accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("CameraPose.tracking_state"), std::string::npos)
        << e.what();
  }
  EXPECT_EQ(core.num_frames(), 0u);
}

}  // namespace
}  // namespace dygslam
