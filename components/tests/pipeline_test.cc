// End-to-end pipeline over DDS on the shared Bonn frames (runs the dygslam binary; netns).
// Every test uses its own DDS domain ids (111..129) so that tests running in parallel never meet
// (/dev/shm is shared between network namespaces).
#include <gtest/gtest.h>
#include <octomap/OcTree.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "core/eval/trajectory_eval.h"
#include "core/io/file_util.h"
#include "core/io/trajectory_io.h"
#include "mapping/octomap_builder.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {

// <build>/apps/dygslam, found from this test executable (<build>/components/dds_pipeline).
std::string Binary() {
  if (const char* dir = std::getenv("DYGSLAM_BINARY_DIR"))
    return std::string(dir) + "/apps/dygslam";
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe");
  return (self.parent_path().parent_path() / "apps" / "dygslam").string();
}
std::string Config() {
  return std::string(std::getenv("DYGSLAM_SOURCE_DIR")) + "/config/bonn.yaml";
}

using testing::ReadAll;

// Starts `args` with stdout + stderr to `log`; new_group: own process group (for a Ctrl-C-like
// signal to the whole group).
pid_t Spawn(const std::vector<std::string>& args, const std::string& log, bool new_group = false) {
  const pid_t pid = fork();
  if (pid == 0) {
    if (new_group) setpgid(0, 0);
    std::vector<char*> argv;
    std::vector<std::string> copy = args;
    for (auto& a : copy) argv.push_back(a.data());
    argv.push_back(nullptr);
    FILE* f = std::freopen(log.c_str(), "w", stderr);
    (void)f;
    dup2(fileno(stderr), fileno(stdout));
    execv(argv[0], argv.data());
    std::_Exit(127);
  }
  if (new_group) setpgid(pid, pid);
  return pid;
}

// Exit code of child `pid`. Every run here ends within a minute even on a loaded machine; one
// still running after 150 s hangs: the test fails at once with its threads' stacks (gdb) instead
// of running into ctest's timeout with no output (and kills it, so the next wait goes on).
int Wait(pid_t pid) {
  std::string hang;
  const int code = testing::WaitForExit(pid, 150, &hang);
  if (code == -1) ADD_FAILURE() << hang;
  return code;
}

// `dygslam run DATASET --config bonn.yaml --frames F --out OUT --domain D --quiet <extra>`.
std::vector<std::string> RunArgs(const std::string& dataset, const std::string& out, int domain,
                                 const std::string& frames, const std::vector<std::string>& extra) {
  std::vector<std::string> a = {Binary(),
                                "run",
                                dataset,
                                "--config",
                                Config(),
                                "--frames",
                                frames,
                                "--out",
                                out,
                                "--domain",
                                std::to_string(domain)};
  a.insert(a.end(), extra.begin(), extra.end());
  return a;
}

int RunToEnd(const std::vector<std::string>& args, const std::string& log) {
  return Wait(Spawn(args, log));
}

// Components by hand: `dygslam component NAME --dataset ... --domain D <extra>`.
std::vector<std::string> ComponentArgs(const std::string& name, const std::string& dataset,
                                       const std::string& out, int domain,
                                       const std::string& frames,
                                       const std::vector<std::string>& extra = {}) {
  std::vector<std::string> a = {Binary(),
                                "component",
                                name,
                                "--dataset",
                                dataset,
                                "--config",
                                Config(),
                                "--out",
                                out,
                                "--frames",
                                frames,
                                "--domain",
                                std::to_string(domain)};
  a.insert(a.end(), extra.begin(), extra.end());
  return a;
}

double AteRmse(const std::string& dataset, const std::string& trajectory) {
  return ComputeAte(ReadTumTrajectory(dataset + "/groundtruth.txt"), ReadTumTrajectory(trajectory))
      .error.rmse;
}

size_t CsvRows(const std::string& path) {
  size_t rows = 0;
  for (const TextLine& line : ReadDataLines(path)) {
    if (!line.tokens.empty() && line.tokens[0] != "stamp") ++rows;
  }
  return rows;
}

std::string FirstLine(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  return line;
}

// --deterministic: the pipeline with one process per component, the pipeline on threads of one
// process and the direct library loop (no DDS) all write the same trajectory file, byte for byte
// (120 frames: people enter from frame ~110, so detections matter), and the same frames.csv
// columns; keyframes.txt and map.bt exist in every mode.
TEST(Pipeline, DeterministicMultiProcessMatchesSingleProcess) {
  DYGSLAM_REQUIRE_DATASET(dataset, "bonn_crowd_part");
  const std::string tmp = testing::MakeTempDir("dds_pipeline_det");
  const std::string frames = "0:120";
  ASSERT_EQ(RunToEnd(RunArgs(dataset, tmp + "/single", 111, frames, {"--deterministic"}),
                     tmp + "/single.log"),
            0)
      << ReadAll(tmp + "/single.log");
  ASSERT_EQ(
      RunToEnd(RunArgs(dataset, tmp + "/multi", 112, frames, {"--deterministic", "--processes"}),
               tmp + "/multi.log"),
      0)
      << ReadAll(tmp + "/multi.log");
  ASSERT_EQ(RunToEnd(RunArgs(dataset, tmp + "/direct", 0, frames, {"--deterministic", "--direct"}),
                     tmp + "/direct.log"),
            0)
      << ReadAll(tmp + "/direct.log");
  const std::string single = ReadAll(tmp + "/single/trajectory.txt");
  EXPECT_GT(ReadTumTrajectory(tmp + "/single/trajectory.txt").size(), 100u);
  EXPECT_EQ(single, ReadAll(tmp + "/multi/trajectory.txt")) << ReadAll(tmp + "/multi.log");
  EXPECT_EQ(single, ReadAll(tmp + "/direct/trajectory.txt"));
  for (const std::string mode : {"single", "multi", "direct"}) {
    const std::string dir = tmp + "/" + mode;
    EXPECT_EQ(FirstLine(dir + "/frames.csv"), FirstLine(tmp + "/direct/frames.csv")) << mode;
    EXPECT_EQ(CsvRows(dir + "/frames.csv"), 120u) << mode;
    EXPECT_GT(ReadTumTrajectory(dir + "/keyframes.txt").size(), 3u) << mode;
    EXPECT_GT(ReadOctoMap(dir + "/map.bt")->size(), 1000u) << mode;
    const std::string log = ReadAll(tmp + "/" + mode + ".log");
    EXPECT_NE(log.find("ATE RMSE"), std::string::npos) << log;
    EXPECT_NE(log.find("frames: 120 processed"), std::string::npos) << log;
  }
}

// Normal mode (asynchronous local mapping, slam does not wait for late detections): one process
// per component tracks as well as the deterministic direct run: ATE within 10 % of it (plus 3 mm
// for run-to-run noise on a 1-2 cm ATE over 150 frames).
TEST(Pipeline, NormalModeMultiProcessAteMatchesDeterministicRun) {
  DYGSLAM_REQUIRE_DATASET(dataset, "bonn_crowd_part");
  const std::string tmp = testing::MakeTempDir("dds_pipeline_normal");
  const std::string frames = "0:150";
  ASSERT_EQ(RunToEnd(RunArgs(dataset, tmp + "/reference", 0, frames,
                             {"--deterministic", "--direct", "--no-map"}),
                     tmp + "/reference.log"),
            0)
      << ReadAll(tmp + "/reference.log");
  ASSERT_EQ(RunToEnd(RunArgs(dataset, tmp + "/multi", 114, frames, {"--processes", "--no-map"}),
                     tmp + "/multi.log"),
            0)
      << ReadAll(tmp + "/multi.log");
  const double reference = AteRmse(dataset, tmp + "/reference/trajectory.txt");
  const double multi = AteRmse(dataset, tmp + "/multi/trajectory.txt");
  EXPECT_GT(ReadTumTrajectory(tmp + "/multi/trajectory.txt").size(), 140u);
  EXPECT_LT(multi, 1.10 * reference + 0.003)
      << "reference " << reference << " m, multi-process " << multi << " m";
  EXPECT_FALSE(std::filesystem::exists(tmp + "/multi/map.bt"));  // --no-map
}

// Ctrl-C (SIGINT to the whole process group) in the middle of a multi-process run: exit 0, and
// trajectory.txt, keyframes.txt, frames.csv and map.bt are complete and loadable.
TEST(Pipeline, SigintMidRunFlushesOutputs) {
  DYGSLAM_REQUIRE_DATASET(dataset, "bonn_crowd_part");
  const std::string tmp = testing::MakeTempDir("dds_pipeline_sigint");
  const std::string log = tmp + "/run.log";
  // Progress line on (no --quiet): "[run] frame k/N" tells how far it got.
  std::vector<std::string> args =
      RunArgs(dataset, tmp + "/out", 115, "0:360", {"--processes", "--filter", "geometry"});
  const pid_t pid = Spawn(args, log, /*new_group=*/true);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (ReadAll(log).find("[run] frame 60/") == std::string::npos &&
         std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ASSERT_NE(ReadAll(log).find("[run] frame 60/"), std::string::npos) << ReadAll(log);
  kill(-pid, SIGINT);
  ASSERT_EQ(Wait(pid), 0) << ReadAll(log);
  const std::string out = tmp + "/out";
  const size_t rows = CsvRows(out + "/frames.csv");
  EXPECT_GE(rows, 60u);
  EXPECT_LT(rows, 360u);
  const auto trajectory = ReadTumTrajectory(out + "/trajectory.txt");
  EXPECT_GE(trajectory.size(), rows - 5) << "every tracked frame";
  EXPECT_GT(ReadTumTrajectory(out + "/keyframes.txt").size(), 2u);
  EXPECT_GT(ReadOctoMap(out + "/map.bt")->size(), 1000u);
  EXPECT_NE(ReadAll(log).find("interrupted"), std::string::npos) << ReadAll(log);
  // Nothing half-written left behind.
  for (const auto& entry : std::filesystem::directory_iterator(out)) {
    EXPECT_EQ(entry.path().string().find(".tmp"), std::string::npos) << entry.path();
  }
}

// SIGTERM to a single-process pipeline and to the direct loop: same guarantees.
TEST(Pipeline, SigtermSingleProcessAndDirectFlushOutputs) {
  DYGSLAM_REQUIRE_DATASET(dataset, "bonn_crowd_part");
  const std::string tmp = testing::MakeTempDir("dds_pipeline_sigterm");
  int domain = 116;
  for (const std::string mode : {"single", "direct"}) {
    const std::string log = tmp + "/" + mode + ".log";
    std::vector<std::string> extra = {"--filter", "geometry"};
    if (mode == "direct") extra.push_back("--direct");
    const pid_t pid = Spawn(RunArgs(dataset, tmp + "/" + mode, domain++, "0:360", extra), log);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
    while (ReadAll(log).find("[run] frame 30/") == std::string::npos &&
           std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    ASSERT_NE(ReadAll(log).find("[run] frame 30/"), std::string::npos) << ReadAll(log);
    kill(pid, SIGTERM);
    ASSERT_EQ(Wait(pid), 0) << ReadAll(log);
    const std::string out = tmp + "/" + mode;
    const size_t rows = CsvRows(out + "/frames.csv");
    EXPECT_GE(rows, 30u) << mode;
    EXPECT_LT(rows, 360u) << mode;
    EXPECT_GE(ReadTumTrajectory(out + "/trajectory.txt").size(), rows - 5) << mode;
    EXPECT_GT(ReadOctoMap(out + "/map.bt")->size(), 1000u) << mode;
  }
}

// A mapper started after slam has emitted keyframes still receives the history: every keyframe
// message while fewer than kKeyframeHistoryDepth (64) were published before it joined, else the
// newest 64 of them, then everything after (transient-local, bounded).
TEST(Pipeline, LateMapperReceivesKeyframeHistory) {
  DYGSLAM_REQUIRE_DATASET(dataset, "bonn_crowd_part");
  const std::string tmp = testing::MakeTempDir("dds_pipeline_late_mapper");
  const int domain = 117;
  const std::string out = tmp + "/out";
  const std::vector<std::string> geometry = {"--filter", "geometry"};
  auto with = [&](std::vector<std::string> a, const std::vector<std::string>& more) {
    a.insert(a.end(), more.begin(), more.end());
    return a;
  };
  const pid_t recorder = Spawn(ComponentArgs("recorder", dataset, out, domain, "0:120", geometry),
                               tmp + "/recorder.log");
  const pid_t slam =
      Spawn(ComponentArgs("slam", dataset, out, domain, "0:120", geometry), tmp + "/slam.log");
  const pid_t player =
      Spawn(ComponentArgs("player", dataset, out, domain, "0:120", with(geometry, {"--rate", "1"})),
            tmp + "/player.log");
  // 120 frames in real time (4 s): the mapper joins once slam has published frames (the recorder
  // writes trajectory_online.txt only at the end, so watch slam's keyframes through time).
  std::this_thread::sleep_for(std::chrono::milliseconds(2500));
  const pid_t mapper =
      Spawn(ComponentArgs("mapper", dataset, out, domain, "0:120", geometry), tmp + "/mapper.log");
  EXPECT_EQ(Wait(slam), 0) << ReadAll(tmp + "/slam.log");
  EXPECT_EQ(Wait(mapper), 0) << ReadAll(tmp + "/mapper.log");
  EXPECT_EQ(Wait(recorder), 0) << ReadAll(tmp + "/recorder.log");
  EXPECT_EQ(Wait(player), 0) << ReadAll(tmp + "/player.log");
  std::smatch m;
  const std::string slam_log = ReadAll(tmp + "/slam.log");
  const std::string mapper_log = ReadAll(tmp + "/mapper.log");
  ASSERT_TRUE(std::regex_search(slam_log, m, std::regex(R"((\d+) keyframe messages \((\d+) new)")))
      << slam_log;
  const int published = std::stoi(m[1]);
  const int published_new = std::stoi(m[2]);
  ASSERT_TRUE(std::regex_search(mapper_log, m,
                                std::regex(R"(mapper: (\d+) keyframe messages \((\d+) new)")))
      << mapper_log;
  EXPECT_GT(published_new, 5);
  const int history = 64;  // dds::kKeyframeHistoryDepth
  EXPECT_GE(std::stoi(m[1]), std::min(published, history)) << mapper_log;
  EXPECT_LE(std::stoi(m[1]), published) << mapper_log;
  EXPECT_GE(std::stoi(m[2]), 1) << mapper_log;
  EXPECT_LE(std::stoi(m[2]), published_new) << mapper_log;
  EXPECT_GT(ReadOctoMap(out + "/map.bt")->size(), 1000u);
}

// Killing the detector (SIGKILL) mid-run does not stop slam: it continues geometry-only, says
// so, and the recorder still writes a trajectory with every frame. slam's part is incomplete
// (exit 3): frames ran without the boxes the run asked for.
TEST(Pipeline, KillingTheDetectorDoesNotStopSlam) {
  DYGSLAM_REQUIRE_DATASET(dataset, "bonn_crowd_part");
  const std::string tmp = testing::MakeTempDir("dds_pipeline_kill");
  const int domain = 113;
  auto run = [&](const std::string& name, const std::vector<std::string>& extra = {}) {
    return Spawn(ComponentArgs(name, dataset, tmp + "/out", domain, "0:90", extra),
                 tmp + "/" + name + ".log");
  };
  const std::vector<std::string> normal = {"--detection-wait-ms", "100"};
  const pid_t recorder = run("recorder");
  const pid_t slam = run("slam", normal);
  const pid_t detector = run("detector");
  const pid_t player = run("player", {"--rate", "1"});  // real time: 3 s of frames
  std::this_thread::sleep_for(std::chrono::milliseconds(1800));
  kill(detector, SIGKILL);
  EXPECT_EQ(Wait(detector), 128 + SIGKILL);
  const int slam_code = Wait(slam);
  EXPECT_EQ(Wait(recorder), 0) << ReadAll(tmp + "/recorder.log");
  EXPECT_EQ(Wait(player), 0) << ReadAll(tmp + "/player.log");
  const std::string slam_log = ReadAll(tmp + "/slam.log");
  // The frames after the carried boxes ran out had no boxes: slam's part is incomplete (exit 3).
  std::smatch m;
  ASSERT_TRUE(
      std::regex_search(slam_log, m, std::regex(R"(carried forward, (\d+) geometry-only\))")))
      << slam_log;
  const int geometry_only = std::stoi(m[1]);
  EXPECT_EQ(slam_code, geometry_only > 0 ? 3 : 0) << slam_log;
  if (geometry_only > 0)
    EXPECT_NE(
        slam_log.find("frames ran without person boxes (geometry-only): the detector was lost"),
        std::string::npos)
        << slam_log;
  EXPECT_NE(slam_log.find("slam: 90 frames"), std::string::npos) << slam_log;
  EXPECT_GT(ReadTumTrajectory(tmp + "/out/trajectory.txt").size(), 80u);
  EXPECT_EQ(CsvRows(tmp + "/out/frames.csv"), 90u);
}

// `dygslam run --processes --security DIR`: every component process authenticates with its own
// identity (DIR/<component> from scripts/make_dds_certs.sh) and the secured pipeline processes
// every frame; a credentials folder that does not exist is a clear error naming it.
TEST(Pipeline, SecureMultiProcessRunProcessesEveryFrame) {
  DYGSLAM_REQUIRE_DATASET(dataset, "bonn_crowd_part");
  const std::string tmp = testing::MakeTempDir("dds_pipeline_secure");
  const std::string certs = tmp + "/certs";
  const std::string script =
      std::string(std::getenv("DYGSLAM_SOURCE_DIR")) + "/scripts/make_dds_certs.sh";
  ASSERT_EQ(std::system((script + " " + certs + " > " + tmp + "/certs.log 2>&1").c_str()), 0)
      << ReadAll(tmp + "/certs.log");
  ASSERT_EQ(RunToEnd(RunArgs(dataset, tmp + "/out", 120, "0:40",
                             {"--processes", "--filter", "geometry", "--security", certs}),
                     tmp + "/run.log"),
            0)
      << ReadAll(tmp + "/run.log");
  EXPECT_EQ(CsvRows(tmp + "/out/frames.csv"), 40u) << ReadAll(tmp + "/run.log");

  const std::string missing = tmp + "/no_such_certs";
  EXPECT_NE(RunToEnd(RunArgs(dataset, tmp + "/bad", 121, "0:10",
                             {"--filter", "geometry", "--security", missing}),
                     tmp + "/bad.log"),
            0);
  EXPECT_NE(ReadAll(tmp + "/bad.log").find("no_such_certs"), std::string::npos)
      << ReadAll(tmp + "/bad.log");

  // One component's identity from another CA (the rogue identity in place of the mapper's): the
  // components could not authenticate each other. Refused before any process starts, naming
  // the component, instead of a run stalled in discovery.
  const std::string mixed = tmp + "/mixed_certs";
  ASSERT_EQ(std::system(("cp -r " + certs + " " + mixed + " && rm -r " + mixed +
                         "/mapper && cp -r " + mixed + "/rogue " + mixed + "/mapper")
                            .c_str()),
            0);
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_NE(RunToEnd(RunArgs(dataset, tmp + "/mixed", 122, "0:10",
                             {"--processes", "--filter", "geometry", "--security", mixed}),
                     tmp + "/mixed.log"),
            0);
  const std::string mixed_log = ReadAll(tmp + "/mixed.log");
  EXPECT_NE(mixed_log.find("component 'mapper' trusts another identity CA than component"),
            std::string::npos)
      << mixed_log;
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(30)) << mixed_log;
}

}  // namespace
}  // namespace dygslam
