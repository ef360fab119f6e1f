// A --direct replay at the camera's rate stopped (SIGSTOP) and continued as a whole. It runs alone
// (RUN_SERIAL): what it checks is the replay's pace, which other tests on the same cores would
// take away (seen: 6.5 frames/s, a stretch of 3.6 s without a frame under three runs on two
// cores).
#include <signal.h>

#include <algorithm>
#include <chrono>
#include <string>
#include <thread>
#include <vector>

#include "core/io/dataset.h"
#include "core/io/trajectory_io.h"
#include "tests/support/cli_fixture.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
using testing::Contains;
using testing::ReadAll;

class PacedPause : public testing::CliFixture {
 protected:
  PacedPause() : CliFixture("paced_pause") {}
  // Started as a supervisor or test harness may start it: with SIGCONT blocked (the mask is
  // inherited across exec), which must not hide the pause from the replay.
  pid_t Spawn(const std::vector<std::string>& args) {
    sigset_t cont, old;
    sigemptyset(&cont);
    sigaddset(&cont, SIGCONT);
    pthread_sigmask(SIG_BLOCK, &cont, &old);
    const pid_t pid = testing::SpawnDygslam(args, dir_ + "/run.out", dir_ + "/run.err");
    pthread_sigmask(SIG_SETMASK, &old, nullptr);
    return pid;
  }
};

// `--direct --rate 1` with the whole process stopped (SIGSTOP) for 5 s and continued: the camera
// of a paused replay is paused too, the replay goes on from the frame it was at. Before, the
// frames of the pause were dropped as if the pipeline could not keep up (20 of 150 processed),
// exit 0; so was it when the process was started with SIGCONT blocked (its handler never ran).
// Each mode treats its own pause the same way.
TEST_F(PacedPause, ADirectReplayStoppedAndContinuedGoesOnFromItsFrame) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string out = dir_ + "/out";
  const pid_t pid = Spawn({"run", source, "--config", Config(), "--filter", "none", "--frames",
                           "0:150", "--no-map", "--direct", "--rate", "1", "--out", out});
  ASSERT_GT(pid, 0);
  // Stopped once the replay goes (an event, not a time: a loaded machine starts slowly).
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (!Contains(ReadAll(dir_ + "/run.err"), "[run] frame ") &&
         std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  ASSERT_TRUE(Contains(ReadAll(dir_ + "/run.err"), "[run] frame ")) << ReadAll(dir_ + "/run.err");
  kill(pid, SIGSTOP);
  std::this_thread::sleep_for(std::chrono::seconds(5));
  kill(pid, SIGCONT);
  std::string diagnostics;
  const int code = testing::WaitForExit(pid, 120, &diagnostics);
  const std::string summary = ReadAll(dir_ + "/run.out"), err = ReadAll(dir_ + "/run.err");
  EXPECT_EQ(code, 0) << summary << err << diagnostics;
  EXPECT_TRUE(Contains(err, "stopped and continued; the replay goes on at the camera's rate"))
      << err;
  // The pause (5 s: as long as the replay) drops no stretch of frames: the poses cover the whole
  // range without a hole of a second. A loaded machine drops single frames at the camera's rate
  // (seen: 6.5 frames/s, 100 of 150 dropped), never a second's worth in a row.
  const auto poses = ReadTumTrajectory(out + "/trajectory.txt");
  ASSERT_GE(poses.size(), 2u) << summary << err;
  double hole = 0;
  for (size_t i = 1; i < poses.size(); ++i)
    hole = std::max(hole, SecondsBetween(poses[i - 1].stamp, poses[i].stamp));
  EXPECT_LT(hole, 1.0) << summary << err;
  const RgbdDataset dataset = RgbdDataset::Open(source);
  EXPECT_LT(SecondsBetween(poses.back().stamp, dataset.StampOfRgbEntry(149)), 1.0)
      << summary << err;
}

}  // namespace
}  // namespace dygslam
