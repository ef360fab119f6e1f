// A local program that joins the run's DDS partition (as one that joins "*" does) and publishes
// forged samples while `dygslam run` works (issue 20 item 3): before the fix the recorder wrote its
// 5-pose Trajectory as trajectory.txt and its CameraPose samples into trajectory_online.txt, and
// the mapper inserted its keyframes. Now the recorder and the mapper take samples only from the
// run's own slam participant, drop and count the others, and say so. Runs in a private network
// namespace (the test emulator), on its own domain.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "components/convert.h"
#include "components/dds/participant.h"
#include "components/dds/pubsub.h"
#include "core/io/trajectory_io.h"
#include "dygslam_msg/CameraPosePubSubTypes.h"
#include "dygslam_msg/KeyframePubSubTypes.h"
#include "dygslam_msg/TrajectoryPubSubTypes.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

std::string ReadAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

constexpr double kForgedStamp = 4242.0;  // far from the dataset's stamps

TEST(DdsForeignWriter, RunIgnoresAndCountsSamplesOfOtherParticipants) {
  DYGSLAM_REQUIRE_DATASET(dataset, "bonn_crowd_part");
  if (!fs::exists(testing::DygslamBinary())) GTEST_SKIP() << "dygslam binary not built";
  const std::string dir = testing::MakeTempDir("dds_foreign");
  const int domain = 42;
  // The intruder: the run's partition (a plain DDS participant can also join "*"; dygslam's own
  // Participant refuses wildcards) and the run's topics.
  const std::string partition = "dygslam_intruded_run";
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
  std::vector<StampedPose> forged;
  for (int i = 0; i < 5; ++i) {
    StampedPose p;
    p.stamp = Timestamp::FromSeconds(kForgedStamp + i);
    p.world_from_cam.translation = Eigen::Vector3d(100.0 + i, 0, 0);
    forged.push_back(p);
  }
  const msg::Trajectory forged_frames = TrajectoryToMsg(forged, false);
  const msg::Trajectory forged_keyframes = TrajectoryToMsg(forged, true);

  const std::vector<std::string> args = {testing::DygslamBinary(),
                                         "run",
                                         dataset,
                                         "--config",
                                         std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/bonn.yaml",
                                         "--filter",
                                         "none",
                                         "--frames",
                                         "0:60",
                                         "--out",
                                         dir + "/out",
                                         "--quiet",
                                         "--domain",
                                         std::to_string(domain),
                                         "--partition",
                                         partition};
  const pid_t pid = fork();
  if (pid == 0) {
    std::vector<std::string> copy = args;
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
      msg::CameraPose pose;
      pose.header().stamp(TimeToMsg(Timestamp::FromSeconds(kForgedStamp + published % 5)));
      pose.tracking_state(1);
      pose.has_pose(true);
      pose.world_from_cam(PoseToMsg(forged[published % 5].world_from_cam));
      pose_writer.Write(pose);
      msg::Keyframe keyframe;
      keyframe.id(1000000 + static_cast<int64_t>(published));
      keyframe_writer.Write(keyframe);
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
  EXPECT_GE(trajectory.size(), 50u) << log;
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
  EXPECT_NE(log.find("outside this run"), std::string::npos) << log;
}

}  // namespace
}  // namespace dygslam
