// A second frame source on a run's partition, end to end:
// `dygslam component player` on another stretch of the dataset, started while `dygslam run`
// plays, must not feed the run. slam names the rival ("rejected a second frame source"), the
// run's player warns, the second player stops by itself (its frames refused) and fails, and the
// run's outputs hold only the run's own frames. The unit half is
// components/protocol_test.cc (Protocol.RunWritersRejectASecondFrameSource). Runs in a private
// network namespace (the test emulator), on DDS domain 194.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include "components/dds/participant.h"
#include "components/dds/pubsub.h"
#include "core/io/dataset.h"
#include "core/io/trajectory_io.h"
#include "dygslam_msg/RgbdFramePubSubTypes.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

constexpr int kDomain = 194;
constexpr int kRunFrames = 200;   // frames [0, 200) of the dataset: the run
constexpr int kRivalFirst = 260;  // frames [260, 360): the second player, in real time
constexpr int kRivalLast = 360;
constexpr int kShortRivalFrames = 5;  // a sixth of a second at the camera's rate

bool Contains(const std::string& text, const std::string& needle) {
  return text.find(needle) != std::string::npos;
}

// Plays the run and, once its frames flow, a second player on frames [rival_first, rival_last)
// at the camera's rate, on `domain`.
void ExpectSecondPlayerRefused(int domain, int rival_first, int rival_last) {
  DYGSLAM_REQUIRE_DATASET(dataset, "bonn_crowd_part");
  DYGSLAM_REQUIRE_FILE(testing::DygslamBinary(), "dygslam binary");
  const RgbdDataset frames = RgbdDataset::Open(dataset);
  ASSERT_GE(frames.size(), size_t(rival_last));
  const std::string dir = testing::MakeTempDir("dds_second_player");
  const std::string partition = "dygslam_second_player_" + std::to_string(getpid());
  const std::string config = std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/bonn.yaml";

  // A watcher on the run's partition: the first frame it sees means the run's player announced
  // itself, so the second player below is the later one (the first to announce plays).
  dds::ParticipantOptions po;
  po.domain_id = domain;
  po.name = "second_player_watcher";
  po.partition = partition;
  auto watcher = dds::Participant::Create(po);
  std::atomic<int> seen{0};
  dds::Reader<msg::RgbdFramePubSubType> frame_reader(watcher, dds::topics::kRgbdFrame,
                                                     dds::TopicKind::kRgbdFrame,
                                                     [&](msg::RgbdFrame&&) { seen.fetch_add(1); });

  const pid_t run =
      testing::SpawnDygslam({"run", dataset, "--config", config, "--filter", "none", "--frames",
                             "0:" + std::to_string(kRunFrames), "--out", dir + "/out", "--domain",
                             std::to_string(domain), "--partition", partition},
                            dir + "/run.out", dir + "/run.err");
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (seen.load() == 0 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  const bool run_started = seen.load() > 0;
  // With the run's filter (no detector): it waits for the run's one frame reader, slam, and
  // plays at once rather than waiting 10 s for a detector that is not there.
  const pid_t rival = testing::SpawnDygslam(
      {"component", "player", "--dataset", dataset, "--config", config, "--filter", "none",
       "--frames", std::to_string(rival_first) + ":" + std::to_string(rival_last), "--rate", "1",
       "--domain", std::to_string(domain), "--partition", partition},
      dir + "/rival.out", dir + "/rival.err");

  std::string diagnostics;
  const int run_code = testing::WaitForExit(run, 240, &diagnostics);
  // The second player sees the poses of the run's frames and none of its own: it stops by itself
  // and fails (before, it waited 30 s for the acknowledgement of each frame).
  std::string rival_diagnostics;
  const int rival_code = testing::WaitForExit(rival, 30, &rival_diagnostics);
  const std::string log = testing::ReadAll(dir + "/run.out") + testing::ReadAll(dir + "/run.err");
  const std::string rival_log =
      testing::ReadAll(dir + "/rival.out") + testing::ReadAll(dir + "/rival.err");
  ASSERT_TRUE(run_started) << "the watcher saw no frame of the run in 60 s\n" << log;
  EXPECT_EQ(run_code, 0) << diagnostics << log;

  // Named: slam rejected the rival, the run's player saw it.
  EXPECT_TRUE(Contains(log, "slam: rejected a second frame source on this run's partition: player"))
      << log << "\n--- second player:\n"
      << rival_log;
  EXPECT_TRUE(Contains(log, "player: another frame source (player)")) << log;
  EXPECT_EQ(rival_code, 1) << rival_diagnostics << rival_log;
  EXPECT_TRUE(Contains(rival_log, "this player's frames are refused; stopping")) << rival_log;
  // The second player's samples (the frames it sent before it stopped, its ground truth) reached
  // the run and were dropped, counted in the summary (without the check its frames would have
  // been tracked).
  std::smatch ignored;
  ASSERT_TRUE(std::regex_search(log, ignored, std::regex(R"(dds: ignored (\d+) samples)"))) << log;
  EXPECT_GT(std::stol(ignored[1]), 0) << log;

  // Only the run's frames: every pose is at a stamp of frames [0, kRunFrames).
  const double last_run_stamp = frames.frame(kRunFrames - 1).rgb_stamp.seconds();
  const double first_rival_stamp = frames.frame(rival_first).rgb_stamp.seconds();
  ASSERT_LT(last_run_stamp, first_rival_stamp);
  const auto trajectory = ReadTumTrajectory(dir + "/out/trajectory.txt");
  EXPECT_GE(trajectory.size(), size_t(kRunFrames * 9 / 10)) << log;
  EXPECT_LE(trajectory.size(), size_t(kRunFrames)) << log;
  for (const char* name : {"trajectory.txt", "trajectory_online.txt"}) {
    for (const StampedPose& p : ReadTumTrajectory(dir + "/out/" + name)) {
      EXPECT_LE(p.stamp.seconds(), last_run_stamp + 1e-3)
          << name << ": a pose of the second player's frames at " << p.stamp.ToString();
    }
  }
  fs::remove_all(dir);
}

TEST(DdsSecondPlayer, RunRejectsASecondFrameSourceOnItsPartition) {
  ExpectSecondPlayerRefused(kDomain, kRivalFirst, kRivalLast);
}

// A second player whose few frames are all sent before a second's worth of the run's poses came
// back learns after its end of stream that its frames were refused, and fails the same way
// (before, it ended saying slam was done early, exit 3).
TEST(DdsSecondPlayer, ASecondPlayerEndedBeforeItSawTheRunsPosesIsStillRefused) {
  ExpectSecondPlayerRefused(kDomain + 2, kRivalFirst, kRivalFirst + kShortRivalFrames);
}

// A second detector on a run's partition (started by hand before the run, with the run's
// --partition): both answer the run's frames. Before, slam used whichever boxes came first and
// nothing said so (the other detector may run another model). Now slam says it, once.
TEST(DdsSecondDetector, ARunSaysWhenASecondDetectorAnswers) {
  DYGSLAM_REQUIRE_DATASET(dataset, "bonn_crowd_part");
  DYGSLAM_REQUIRE_MODELS(models);
  DYGSLAM_REQUIRE_FILE(testing::DygslamBinary(), "dygslam binary");
  const std::string dir = testing::MakeTempDir("dds_second_detector");
  const std::string partition = "dygslam_second_detector_" + std::to_string(getpid());
  const std::string config = std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/bonn.yaml";
  const std::string domain = std::to_string(kDomain + 1);
  const pid_t second = testing::SpawnDygslam(
      {"component", "detector", "--config", config, "--domain", domain, "--partition", partition},
      dir + "/detector.out", dir + "/detector.err");
  std::this_thread::sleep_for(std::chrono::seconds(2));  // its model loaded, its writer up
  const pid_t run = testing::SpawnDygslam(
      {"run", dataset, "--config", config, "--filter", "full", "--frames", "0:90", "--no-map",
       "--out", dir + "/out", "--domain", domain, "--partition", partition},
      dir + "/run.out", dir + "/run.err");
  std::string diagnostics;
  const int run_code = testing::WaitForExit(run, 240, &diagnostics);
  kill(second, SIGINT);
  std::string second_diagnostics;
  testing::WaitForExit(second, 30, &second_diagnostics);
  const std::string log = testing::ReadAll(dir + "/run.out") + testing::ReadAll(dir + "/run.err");
  EXPECT_EQ(run_code, 0) << diagnostics << log;
  EXPECT_TRUE(Contains(log, "slam: boxes for one frame came from two detectors")) << log;
  EXPECT_EQ(ReadTumTrajectory(dir + "/out/trajectory.txt").size(), 90u) << log;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace dygslam
