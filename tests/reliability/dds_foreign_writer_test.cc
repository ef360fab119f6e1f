// A local program that joins the run's DDS partition (as one that joins "*" does) and publishes
// forged samples while `dygslam run` works: before the fix the recorder wrote its
// 5-pose Trajectory as trajectory.txt and its CameraPose samples into trajectory_online.txt, the
// mapper inserted its keyframes and slam tracked its frames. Now the recorder, the mapper and slam
// take samples only from the writers the run's components announced (components/protocol.h),
// drop and count the others, and say so. Runs in a private network namespace (the test
// emulator), on its own domain.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <opencv2/core.hpp>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include "components/convert.h"
#include "components/dds/participant.h"
#include "components/dds/pubsub.h"
#include "core/io/trajectory_io.h"
#include "dygslam_msg/CameraPosePubSubTypes.h"
#include "dygslam_msg/DetectionsPubSubTypes.h"
#include "dygslam_msg/KeyframePubSubTypes.h"
#include "dygslam_msg/RgbdFramePubSubTypes.h"
#include "dygslam_msg/TrajectoryPubSubTypes.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

using testing::ReadAll;

constexpr double kForgedStamp = 4242.0;  // far from the dataset's stamps

// `dygslam run` (threads, or one process per component with `processes`) on `domain` while an
// intruder publishes into its partition: the run's outputs have none of the forged samples, each
// component counts what it ignored, and the run summary gives the total.
void RunWithIntruder(const std::string& dataset, bool processes, int domain) {
  const std::string dir = testing::MakeTempDir(processes ? "dds_foreign_processes" : "dds_foreign");
  // The intruder: the run's partition (a plain DDS participant can also join "*"; dygslam's own
  // Participant refuses wildcards) and the run's topics.
  const std::string partition = "dygslam_intruded_run_" + std::to_string(domain);
  dds::ParticipantOptions po;
  po.domain_id = domain;
  po.name = "intruder";
  po.partition = partition;
  auto intruder = dds::Participant::Create(po);
  dds::Writer<msg::TrajectoryPubSubType> trajectory_writer(intruder, dds::topics::kTrajectory,
                                                           dds::TopicKind::kTrajectory);
  dds::Writer<msg::CameraPosePubSubType> pose_writer(intruder, dds::topics::kCameraPose,
                                                     dds::TopicKind::kCameraPose);
  dds::Writer<msg::KeyframePubSubType> keyframe_writer(intruder, dds::topics::kKeyframe,
                                                       dds::TopicKind::kKeyframe);
  dds::Writer<msg::RgbdFramePubSubType> frame_writer(intruder, dds::topics::kRgbdFrame,
                                                     dds::TopicKind::kRgbdFrame);
  dds::Writer<msg::DetectionsPubSubType> detections_writer(intruder, dds::topics::kDetections,
                                                           dds::TopicKind::kDetections);
  // A well-formed frame of the run's size (bonn.yaml: 640x480) with a forged stamp: slam would
  // track it (a frames.csv row at that stamp) if it took it.
  RgbdFrameData forged_frame;
  forged_frame.camera.fx = forged_frame.camera.fy = 540;
  forged_frame.camera.cx = 320;
  forged_frame.camera.cy = 240;
  forged_frame.rgb = cv::Mat(480, 640, CV_8UC3, cv::Scalar(90, 120, 150));
  cv::randu(forged_frame.rgb, cv::Scalar::all(0), cv::Scalar::all(255));
  forged_frame.depth = cv::Mat(480, 640, CV_16UC1, cv::Scalar(10000));
  std::vector<StampedPose> forged;
  for (int i = 0; i < 5; ++i) {
    StampedPose p;
    p.stamp = Timestamp::FromSeconds(kForgedStamp + i);
    p.world_from_cam.translation = Eigen::Vector3d(100.0 + i, 0, 0);
    forged.push_back(p);
  }
  const msg::Trajectory forged_frames = TrajectoryToMsg(forged, false);
  const msg::Trajectory forged_keyframes = TrajectoryToMsg(forged, true);

  // 150 frames (~5-10 s): long enough that every component (a process of its own with
  // --processes) has discovered the intruder before the end, also on a loaded machine where a
  // lost initial announcement means waiting for the next periodic one (60 frames, ~3.6 s, once
  // ended before the mapper had matched the intruder's keyframe writer).
  const std::vector<std::string> args = {testing::DygslamBinary(),
                                         "run",
                                         dataset,
                                         "--config",
                                         std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/bonn.yaml",
                                         "--filter",
                                         "none",
                                         "--frames",
                                         "0:150",
                                         "--out",
                                         dir + "/out",
                                         "--quiet",
                                         "--domain",
                                         std::to_string(domain),
                                         "--partition",
                                         partition};
  std::vector<std::string> run_args = args;
  if (processes) run_args.push_back("--processes");
  const pid_t pid = fork();
  if (pid == 0) {
    std::vector<std::string> copy = run_args;
    std::vector<char*> argv;
    for (auto& a : copy) argv.push_back(a.data());
    argv.push_back(nullptr);
    if (!std::freopen((dir + "/stdout.txt").c_str(), "w", stdout) ||
        !std::freopen((dir + "/stderr.txt").c_str(), "w", stderr))
      std::_Exit(126);
    execv(argv[0], argv.data());
    std::_Exit(127);
  }
  // Publish forged samples until the run ends (bounded: 300 s).
  int status = 0;
  size_t published = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(300);
  while (waitpid(pid, &status, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() > deadline) {
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
      FAIL() << "dygslam run did not end";
    }
    if (trajectory_writer.matched() > 0) {
      trajectory_writer.Write(forged_frames);
      trajectory_writer.Write(forged_keyframes);
      // Poses in bursts, more of them in the run's first second than a rival slam would give
      // (the player must not take them for the consumers' poses of another frame source: they
      // come from no announced slam).
      for (int i = 0; i < 5; ++i) {
        msg::CameraPose pose;
        pose.header().seq(published);
        pose.header().stamp(TimeToMsg(Timestamp::FromSeconds(kForgedStamp + i)));
        pose.tracking_state(1);
        pose.has_pose(true);
        pose.world_from_cam(PoseToMsg(forged[i].world_from_cam));
        pose_writer.Write(pose);
      }
      msg::Keyframe keyframe;
      keyframe.id(1000000 + static_cast<int64_t>(published));
      keyframe_writer.Write(keyframe);
      forged_frame.stamp = Timestamp::FromSeconds(kForgedStamp + published % 5);
      forged_frame.seq = published;
      if (published % 5 == 0) frame_writer.Write(RgbdFrameToMsg(forged_frame));  // 1.5 MB each
      detections_writer.Write(DetectionsToMsg({}, forged_frame.stamp, published, 1.0));
      ++published;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  const std::string log = ReadAll(dir + "/stdout.txt") + ReadAll(dir + "/stderr.txt");
  ASSERT_TRUE(WIFEXITED(status)) << log;
  EXPECT_EQ(WEXITSTATUS(status), 0) << log;
  ASSERT_GT(published, 10u) << "the intruder never matched the run's readers\n" << log;
  // The run's own trajectory, none of the forged poses.
  const auto trajectory = ReadTumTrajectory(dir + "/out/trajectory.txt");
  EXPECT_GE(trajectory.size(), 140u) << log;
  EXPECT_EQ(ReadAll(dir + "/out/frames.csv").find("\n4242."), std::string::npos)
      << "slam tracked a forged frame";
  for (const char* name : {"trajectory.txt", "trajectory_online.txt", "keyframes.txt"}) {
    for (const StampedPose& p : ReadTumTrajectory(dir + "/out/" + name)) {
      const bool forged_stamp =
          p.stamp.seconds() > kForgedStamp - 1 && p.stamp.seconds() < kForgedStamp + 10;
      EXPECT_FALSE(forged_stamp) << name << " has a forged pose at " << p.stamp.ToString();
    }
  }
  // Counted and reported.
  EXPECT_NE(log.find("recorder: ignored"), std::string::npos) << log;
  EXPECT_NE(log.find("mapper: ignored"), std::string::npos) << log;
  // slam: the forged frames (and detections) were ignored, its own 150 frames processed.
  std::smatch m;
  ASSERT_TRUE(
      std::regex_search(log, m, std::regex(R"(slam: ignored (\d+) frames and (\d+) detections)")))
      << log;
  EXPECT_GT(std::stol(m[1]), 0) << log;
  EXPECT_GT(std::stol(m[2]), 0) << log;
  EXPECT_NE(log.find("slam: 150 frames"), std::string::npos) << log;
  // And the run's summary (stdout) gives the total of the components' counts (in both modes;
  // with --processes each child reports its count to the runner).
  size_t components_total = std::stoul(m[1]) + std::stoul(m[2]);
  for (const char* name : {"recorder", "mapper"}) {
    std::smatch count;
    ASSERT_TRUE(
        std::regex_search(log, count, std::regex(std::string(name) + R"(: ignored (\d+) )")))
        << log;
    components_total += std::stoul(count[1]);
  }
  const std::string summary = ReadAll(dir + "/stdout.txt");
  std::smatch total;
  ASSERT_TRUE(std::regex_search(summary, total, std::regex(R"(dds: ignored (\d+) samples)")))
      << log;
  EXPECT_EQ(std::stoul(total[1]), components_total) << log;
  EXPECT_NE(log.find("outside this run"), std::string::npos) << log;
}

TEST(DdsForeignWriter, RunIgnoresAndCountsSamplesOfOtherParticipants) {
  DYGSLAM_REQUIRE_DATASET(dataset, "bonn_crowd_part");
  if (!fs::exists(testing::DygslamBinary())) GTEST_SKIP() << "dygslam binary not built";
  RunWithIntruder(dataset, false, 42);
}

TEST(DdsForeignWriter, ProcessesRunSummaryCountsTheIgnoredSamplesToo) {
  DYGSLAM_REQUIRE_DATASET(dataset, "bonn_crowd_part");
  if (!fs::exists(testing::DygslamBinary())) GTEST_SKIP() << "dygslam binary not built";
  RunWithIntruder(dataset, true, 210);
}

}  // namespace
}  // namespace dygslam
