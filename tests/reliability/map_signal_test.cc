// `dygslam map` stopped by SIGINT / SIGTERM: before the fix it ended with rc
// 130/143 and an empty output folder. Now it stops like `run`: the map is finished from the frames
// processed so far, every output is written atomically (map.bt/.ot, trajectories, pictures) and
// the exit code is 0 -- also for a signal that arrives right after start-up.
#include <gtest/gtest.h>
#include <octomap/OcTree.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "core/base/stop_signal.h"
#include "core/io/trajectory_io.h"
#include "mapping/octomap_builder.h"
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

pid_t Spawn(const std::vector<std::string>& args, const std::string& out, const std::string& err) {
  return testing::SpawnDygslam(args, out, err);
}

int Wait(pid_t pid) {
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

// The number of the last "[map] frame N/" progress line in `path` (0 if none yet).
int LastProgressFrame(const std::string& path) {
  const std::string text = ReadAll(path);
  const size_t at = text.rfind("[map] frame ");
  if (at == std::string::npos) return 0;
  return std::atoi(text.c_str() + at + 12);
}

struct Case {
  int signal;
  int after_frames;  // 0: right after the handlers are installed
};

class MapSignal : public ::testing::TestWithParam<Case> {};

TEST_P(MapSignal, StopsWithEveryOutputWritten) {
  DYGSLAM_REQUIRE_DATASET(dataset, "bonn_crowd_part");
  if (!fs::exists(testing::DygslamBinary())) GTEST_SKIP() << "dygslam binary not built";
  const Case c = GetParam();
  const std::string dir = testing::MakeTempDir("map_signal");
  const std::string out = dir + "/out";
  const pid_t pid =
      Spawn({"map", dataset, "--config", std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/bonn.yaml",
             "--filter", "geometry", "--frames", "0:300", "--out", out},
            dir + "/stdout.txt", dir + "/stderr.txt");
  // Count from the moment the process catches the signal (dygslam's main installs the handler
  // first thing): before that, exec and dynamic loading would end it like any program.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  bool ready = false;
  while (!ready && std::chrono::steady_clock::now() < deadline) {
    ready = ProcessCatchesSignal(pid, c.signal) &&
            (c.after_frames == 0 || LastProgressFrame(dir + "/stderr.txt") >= c.after_frames);
    if (!ready) std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  EXPECT_TRUE(ready) << "no handler or no progress\n" << ReadAll(dir + "/stderr.txt");
  kill(pid, c.signal);
  const int code = Wait(pid);
  const std::string log = ReadAll(dir + "/stdout.txt") + ReadAll(dir + "/stderr.txt");
  EXPECT_EQ(code, 0) << log;
  EXPECT_NE(log.find("interrupted by a signal"), std::string::npos) << log;
  for (const char* name :
       {"map.bt", "map.ot", "map_top.png", "map_slice.png", "trajectory.txt", "keyframes.txt"}) {
    EXPECT_TRUE(fs::exists(out + "/" + name)) << name << " missing\n" << log;
  }
  for (const auto& e : fs::directory_iterator(out)) {
    EXPECT_EQ(e.path().string().find(".tmp"), std::string::npos) << "left behind: " << e.path();
  }
  ASSERT_TRUE(fs::exists(out + "/map.bt"));
  EXPECT_NO_THROW(ReadOctoMap(out + "/map.bt"));
  EXPECT_NO_THROW(ReadOctoMap(out + "/map.ot"));
  const auto trajectory = ReadTumTrajectory(out + "/trajectory.txt");
  if (c.after_frames > 0) {
    // The frames processed before the signal are in the outputs, and not all 300 were.
    EXPECT_GE(trajectory.size(), static_cast<size_t>(c.after_frames) * 9 / 10) << log;
    EXPECT_LT(trajectory.size(), 300u) << log;
    EXPECT_GT(ReadOctoMap(out + "/map.bt")->size(), 0u);
  }
}

INSTANTIATE_TEST_SUITE_P(Signals, MapSignal,
                         ::testing::Values(Case{SIGINT, 30}, Case{SIGTERM, 30}, Case{SIGTERM, 0},
                                           Case{SIGINT, 0}, Case{SIGHUP, 30}),
                         [](const ::testing::TestParamInfo<Case>& info) {
                           const int sig = info.param.signal;
                           return std::string(sig == SIGINT   ? "Sigint"
                                              : sig == SIGHUP ? "Sighup"
                                                              : "Sigterm") +
                                  (info.param.after_frames == 0 ? "AtStart" : "MidRun");
                         });

// A closed output pipe (`dygslam run ... | head -c 1`): the writes fail with EPIPE, the run is not
// killed by SIGPIPE (before: rc 141 and an empty --out), it finishes with every output.
TEST(OutputPipe, ClosedReaderDoesNotKillTheRun) {
  DYGSLAM_REQUIRE_DATASET(data, "bonn_crowd_part");
  const std::string out = testing::MakeTempDir("output_pipe") + "/out";
  const std::string command = "bash -c '\"" + testing::DygslamBinary() + "\" run \"" + data +
                              "\" --config \"" + std::string(DYGSLAM_TEST_SOURCE_DIR) +
                              "/config/bonn.yaml\" --direct --filter none --frames 0:30 --out \"" +
                              out + "\" 2>&1 | head -c 1 > /dev/null; exit ${PIPESTATUS[0]}'";
  const int status = std::system(command.c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << "141 = killed by SIGPIPE";
  EXPECT_EQ(ReadTumTrajectory(out + "/trajectory.txt").size(), 30u);
}

}  // namespace
}  // namespace dygslam
