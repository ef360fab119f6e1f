// The DDS run's integrity (default mode: the components on threads of one process). Outputs are
// transactional there too: nothing in --out is deleted when the run starts (before, 0.3 s in, an
// earlier run's trajectory.txt, map.bt and frames.csv were gone, and a run killed then left
// nothing); at every moment each output is either the earlier run's file or this run's complete
// one. A run cut short without being asked to (an END_OF_STREAM published into the run's
// partition by a participant that is not part of it) never exits 0 with fewer frames than
// requested. Runs in a private network namespace (the test emulator), on its own domains.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include "components/dds/participant.h"
#include "components/dds/pubsub.h"
#include "components/protocol.h"
#include "core/base/stop_signal.h"
#include "core/io/dataset.h"
#include "core/io/trajectory_io.h"
#include "dygslam_msg/StreamStatusPubSubTypes.h"
#include "run/realtime_report.h"
#include "tests/support/cli_fixture.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;
using testing::Contains;
using testing::ReadAll;

constexpr int kKeepDomain = 141;
constexpr int kIntruderDomain = 142;
constexpr int kFailedDomain = 143;
constexpr int kRateDomain = 144;
constexpr int kRivalDomain = 145;
constexpr int kStoppedDomain = 146;
constexpr int kLoopDomain = 147;
constexpr int kPausedDomain = 148;
constexpr int kSwappedDomain = 149;
constexpr int kStallDomain = 150;
constexpr int kSwappedProcessesDomain = 151;
constexpr int kPlayerPausedDomain = 152;
constexpr int kKilledRunDomain = 153;
constexpr int kDetectorPausedDomain = 154;
constexpr int kSuspendedDomain = 155;
constexpr int kDetectorLostDomain = 157;
constexpr int kShortStallDomain = 156;
constexpr int kMapperPausedFromStartDomain = 158;
constexpr int kFasterThanTrackedDomain = 159;

class RunIntegrity : public testing::CliFixture {
 protected:
  RunIntegrity() : CliFixture("run_integrity") {}

  pid_t Spawn(const std::vector<std::string>& args) {
    return testing::SpawnDygslam(args, dir_ + "/run.out", dir_ + "/run.err");
  }
  void ExpectOutputFolderReplacedMidRunIsNeverWrittenThrough(const std::string& source, int domain,
                                                             const std::vector<std::string>& extra);
  // `run --processes --rate 1` on `frames` into dir_/out whose `component` is stopped (SIGSTOP)
  // `after` the frames began to flow and continued `paused` later; the run's exit code (-1 and
  // a failure when the run or the component could not be found).
  int RunWithComponentPaused(const std::string& source, const std::string& component,
                             const std::string& frames, int domain, std::chrono::seconds after,
                             std::chrono::seconds paused, std::string* diagnostics);
};

bool Exited(pid_t pid, int* code) {
  int status = 0;
  if (waitpid(pid, &status, WNOHANG) != pid) return false;
  *code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  return true;
}

// The pid of `dygslam component NAME` whose command line holds `marker` (the run's --out), or 0.
pid_t ComponentPid(const std::string& name, const std::string& marker) {
  for (const auto& entry : fs::directory_iterator("/proc")) {
    const std::string pid_text = entry.path().filename().string();
    if (pid_text.find_first_not_of("0123456789") != std::string::npos) continue;
    std::ifstream cmdline_file(entry.path() / "cmdline");
    std::vector<std::string> argv;
    for (std::string arg; std::getline(cmdline_file, arg, '\0');) argv.push_back(arg);
    if (argv.size() > 2 && argv[1] == "component" && argv[2] == name &&
        std::find(argv.begin(), argv.end(), marker) != argv.end())
      return static_cast<pid_t>(std::stol(pid_text));
  }
  return 0;
}

// Whether process `pid` holds a descriptor of `folder` (a command pins its output folder so).
bool HoldsFolder(pid_t pid, const fs::path& folder) {
  std::error_code ec;
  for (const auto& fd : fs::directory_iterator("/proc/" + std::to_string(pid) + "/fd", ec)) {
    std::error_code link_ec;
    if (fs::read_symlink(fd.path(), link_ec) == folder) return true;
  }
  return false;
}

// The pid of the run's `component NAME` once it catches SIGTERM (its main() runs), waiting at most
// 60 s; 0 when it did not come.
pid_t RunningComponentPid(const std::string& name, const std::string& marker) {
  pid_t pid = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while ((pid == 0 || !ProcessCatchesSignal(pid, SIGTERM)) &&
         std::chrono::steady_clock::now() < deadline) {
    pid = ComponentPid(name, marker);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return pid != 0 && ProcessCatchesSignal(pid, SIGTERM) ? pid : 0;
}

WriterGuid GuidOf(uint8_t participant, uint8_t entity) {
  WriterGuid g{};
  g.fill(participant);
  g[15] = entity;
  return g;
}

// The rule behind the test below: an end of stream or of a component is the run's only from a
// participant that announced a component of the run; others are ignored and counted. A FAILED is
// taken from anyone (a component can fail before it announces itself).
TEST(RunIntegrityRule, EndsFromParticipantsThatAnnouncedNothingAreIgnoredAndCounted) {
  RunWriters writers;
  const WriterGuid player_status = GuidOf(1, 4), player_frames = GuidOf(1, 2);
  const WriterGuid stranger = GuidOf(7, 4);
  EXPECT_FALSE(
      writers.Announce(ComponentStatus::EndOfStream(ComponentKind::kPlayer, 20, 19), stranger));
  EXPECT_FALSE(writers.Announce(ComponentStatus::Done(ComponentKind::kSlam, 20), stranger));
  EXPECT_EQ(writers.NumForeignStatuses(), 2u);
  EXPECT_TRUE(writers.Announce(
      ComponentStatus::Started(ComponentKind::kPlayer, {{DataTopic::kFrames, player_frames}}),
      player_status));
  EXPECT_FALSE(
      writers.Announce(ComponentStatus::EndOfStream(ComponentKind::kPlayer, 20, 19), stranger));
  EXPECT_EQ(writers.NumForeignStatuses(), 3u);
  EXPECT_TRUE(writers.Announce(ComponentStatus::Failed(ComponentKind::kDetector, "x"), stranger));
  EXPECT_TRUE(writers.Announce(ComponentStatus::EndOfStream(ComponentKind::kPlayer, 150, 149),
                               player_status));
  EXPECT_EQ(writers.NumForeignStatuses(), 3u);
  // Without the status writer's GUID (no participant known) the status is taken as before.
  RunWriters plain;
  EXPECT_TRUE(plain.Announce(ComponentStatus::EndOfStream(ComponentKind::kPlayer, 20, 19)));
}

TEST_F(RunIntegrity, EarlierOutputsStayUntilTheRunReplacesThem) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string data = SmallDataset(source, 40, "data");
  const fs::path out = fs::path(dir_) / "out";
  fs::create_directories(out);
  // An earlier run's files (each of its kind: a run replaces only its own outputs).
  const std::map<std::string, std::string> earlier = {
      {"trajectory.txt", "# an earlier run's file\n"},
      {"keyframes.txt", "# an earlier run's file\n"},
      {"frames.csv", "stamp,state\n"},
      {"map.bt", "# Octomap OcTree binary file\n# an earlier run's file\n"}};
  std::vector<std::string> names;
  for (const auto& [name, text] : earlier) {
    std::ofstream(out / name) << text;
    names.push_back(name);
  }
  const pid_t pid = Spawn({"run", data, "--config", Config(), "--filter", "none", "--quiet",
                           "--out", out.string(), "--domain", std::to_string(kKeepDomain)});
  // Until the run ends, every output is there: the earlier file or a complete new one.
  int code = -1;
  size_t checks = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(240);
  while (!Exited(pid, &code)) {
    ASSERT_LT(std::chrono::steady_clock::now(), deadline) << "run did not end";
    for (const std::string& name : names) {
      const std::string text = ReadAll((out / name).string());
      ASSERT_FALSE(text.empty()) << name << " missing or empty during the run (check " << checks
                                 << ")";
      if (text == earlier.at(name)) continue;
      // Replaced: complete (a TUM file or frames.csv ends with a newline; map.bt holds a tree).
      if (name != "map.bt") {
        EXPECT_EQ(text.back(), '\n') << name;
      }
    }
    ++checks;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  EXPECT_GT(checks, 10u);
  ASSERT_EQ(code, 0) << ReadAll(dir_ + "/run.err");
  // This run replaced each of them.
  for (const std::string& name : names)
    EXPECT_NE(ReadAll((out / name).string()), earlier.at(name)) << name << " not replaced";
  const std::string summary = ReadAll(dir_ + "/run.out");
  EXPECT_TRUE(Contains(summary,
                       "/{trajectory.txt,trajectory_online.txt,keyframes.txt,frames.csv,"
                       "map.bt,eval.json}"))
      << summary;
  for (const auto& entry : fs::directory_iterator(out))
    EXPECT_FALSE(Contains(entry.path().filename().string(), ".tmp.")) << entry.path();
}

// A participant outside the run publishes `forged` statuses into the run's partition on `domain`,
// every 100 ms from `delay` after the start on, once a reader of the run has matched its writer
// (a run can end before a fixed delay has passed); returns the frames the run processed, with its
// exit code in `*code`. `extra` are further options of the run.
int RunWithForgedStatus(const std::string& source, const std::string& dir, int domain,
                        const msg::StreamStatus& forged, std::chrono::milliseconds delay, int* code,
                        const std::vector<std::string>& extra = {}) {
  const std::string partition = "dygslam_integrity_" + std::to_string(domain);
  dds::ParticipantOptions po;
  po.domain_id = domain;
  po.name = "intruder";
  po.partition = partition;
  auto intruder = dds::Participant::Create(po);
  dds::Writer<msg::StreamStatusPubSubType> status_writer(intruder, dds::topics::kStreamStatus,
                                                         dds::TopicKind::kStreamStatus);
  std::vector<std::string> args = {
      "run",         source,
      "--config",    std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/bonn.yaml",
      "--filter",    "none",
      "--quiet",     "--frames",
      "0:150",       "--no-map",
      "--out",       dir + "/out",
      "--domain",    std::to_string(domain),
      "--partition", partition};
  args.insert(args.end(), extra.begin(), extra.end());
  const pid_t pid = testing::SpawnDygslam(args, dir + "/run.out", dir + "/run.err");
  const auto start = std::chrono::steady_clock::now();
  while (!Exited(pid, code)) {
    if (std::chrono::steady_clock::now() > start + std::chrono::seconds(280)) {
      kill(pid, SIGKILL);
      ADD_FAILURE() << "run did not end";
      return -1;
    }
    if (std::chrono::steady_clock::now() > start + delay && status_writer.matched() > 0)
      status_writer.Write(forged);
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  const std::string summary = ReadAll(dir + "/run.out");
  std::smatch m;
  if (!std::regex_search(summary, m, std::regex("frames: ([0-9]+) processed"))) {
    ADD_FAILURE() << summary << ReadAll(dir + "/run.err");
    return -1;
  }
  return std::stoi(m[1]);
}

// A participant outside the run publishes END_OF_STREAM statuses into the run's partition:
// before, the run ended early (20 of 150 frames) with exit 0. Now the status is not the run's:
// every frame is processed. The frames come at the camera's rate (5 s), so that the intruder is
// discovered and its statuses reach the run long before the stream ends (at full speed the run
// can end before a slow discovery completes, and then nothing forged ever arrives).
TEST_F(RunIntegrity, AForeignEndOfStreamIsIgnored) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  int code = -1;
  const int processed =
      RunWithForgedStatus(source, dir_, kIntruderDomain,
                          ToMsg(ComponentStatus::EndOfStream(ComponentKind::kPlayer, 20, 20)),
                          std::chrono::milliseconds(0), &code, {"--rate", "1"});
  const std::string summary = ReadAll(dir_ + "/run.out"), err = ReadAll(dir_ + "/run.err");
  EXPECT_EQ(code, 0) << summary << err;
  EXPECT_TRUE(Contains(err,
                       "end-of-stream / done statuses of participants "
                       "that announced no component"))
      << err;
  // Every frame reached the pipeline; the ones it could not take at the camera's pace (none on
  // an idle machine) are counted as dropped, and nothing else is missing.
  std::smatch m;
  ASSERT_TRUE(std::regex_search(summary, m,
                                std::regex("real time: rate 1.00x: 150 frames, "
                                           "([0-9]+) dropped")))
      << summary;
  const int dropped = std::stoi(m[1]);
  EXPECT_EQ(processed + dropped, 150) << summary;
  const std::string json = ReadAll(dir_ + "/out/eval.json");
  EXPECT_TRUE(Contains(json, "\"requested\": 150, \"without_depth_partner\": 0, \"processed\": " +
                                 std::to_string(processed) + ","))
      << json;
  if (dropped == 0) {
    EXPECT_TRUE(Contains(summary, "integrity: 150 of 150 requested frames processed (complete)"))
        << summary;
    EXPECT_TRUE(Contains(json, "\"complete\": true, \"shortfall\": \"none\"")) << json;
  } else {
    EXPECT_TRUE(Contains(json, "\"shortfall\": \"dropped: ")) << json;
  }
  EXPECT_TRUE(Contains(json, "\"exit_code\": 0}")) << json;
}

// A FAILED is taken from any participant (a component can fail before announcing itself), so a
// forged one can end the run early: then the run says that frames are missing and exits non-zero
// (3: cut short), never 0.
TEST_F(RunIntegrity, ARunCutShortNeverExitsZero) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  int code = -1;
  const int processed = RunWithForgedStatus(
      source, dir_, kFailedDomain, ToMsg(ComponentStatus::Failed(ComponentKind::kPlayer, "forged")),
      std::chrono::milliseconds(1500), &code);
  const std::string summary = ReadAll(dir_ + "/run.out"), err = ReadAll(dir_ + "/run.err");
  std::printf("forged FAILED: %d of 150 frames, exit %d\n", processed, code);
  ASSERT_GE(processed, 0);
  if (processed < 150) {
    EXPECT_NE(code, 0) << summary << err;
    if (code == 3) {
      EXPECT_TRUE(Contains(summary, "run incomplete: " + std::to_string(processed) +
                                        " of the 150 requested frames processed"))
          << summary;
      EXPECT_TRUE(Contains(summary, "integrity: " + std::to_string(processed) +
                                        " of 150 requested frames processed, " +
                                        std::to_string(150 - processed) +
                                        " missing, 0 not this run's: the stream was cut short"))
          << summary;
      const std::string json = ReadAll(dir_ + "/out/eval.json");
      EXPECT_TRUE(Contains(json, "\"missing\": " + std::to_string(150 - processed))) << json;
      EXPECT_TRUE(Contains(json, "\"complete\": false, \"shortfall\": \"the stream was cut"))
          << json;
      EXPECT_TRUE(Contains(json, "\"exit_code\": 3}")) << json;
      EXPECT_TRUE(Contains(
          err, "the run ended with " + std::to_string(processed) + " of the 150 requested frames"))
          << err;
    }
  } else {
    EXPECT_EQ(code, 0) << summary << err;
  }
}

// `--processes --rate 1`: the player paces the frames like a camera (no back-pressure window,
// which the component command accepts as 0); every frame arrives and eval.json carries the
// real-time report. Before, every component refused `--window 0` and the run failed.
TEST_F(RunIntegrity, ProcessesRunAtCameraRate) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const auto r = RunWithin({"run", source, "--config", Config(), "--filter", "none", "--quiet",
                            "--frames", "0:30", "--no-map", "--processes", "--rate", "1", "--out",
                            dir_ + "/out", "--domain", std::to_string(kRateDomain)},
                           120);
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  EXPECT_TRUE(Contains(r.out, "real time: rate 1.00x: 30 frames")) << r.out;
  const std::string json = ReadAll(dir_ + "/out/eval.json");
  EXPECT_TRUE(Contains(json, "\"realtime\": {\"rate\": 1, \"frames\": 30,")) << json;
  // The player (its own process) wrote each result's latency: frames of the run, in order, and
  // the median the summary gives is theirs.
  const RealtimeReport report = ReadRealtimeReport(dir_ + "/out/realtime.txt");
  ASSERT_FALSE(report.latencies.empty());
  EXPECT_LE(report.latencies.size(), report.results);
  const RgbdDataset dataset = RgbdDataset::Open(source);
  std::vector<double> ms;
  for (size_t i = 0; i < report.latencies.size(); ++i) {
    const ResultLatency& l = report.latencies[i];
    EXPECT_GT(l.ms, 0.0) << i;
    if (i > 0) EXPECT_LT(report.latencies[i - 1].stamp, l.stamp) << i;
    EXPECT_GE(l.stamp, dataset.frame(0).rgb_stamp) << i;
    EXPECT_LE(l.stamp, dataset.frame(29).rgb_stamp) << i;
    ms.push_back(l.ms);
  }
  std::sort(ms.begin(), ms.end());
  EXPECT_NEAR(ms[ms.size() / 2], report.latency_median_ms, 0.01);
}

// --processes --rate 10: frames come far faster than slam tracks them. A camera does not wait:
// slam keeps at most the frame topic's history of waiting frames and drops the older ones
// (counted), so each pose is at most a few frames old. Before, slam queued every frame: nothing
// was dropped by slam and the latency grew with the run (99th percentile 2.8 s over these 300
// frames).
TEST_F(RunIntegrity, FramesFasterThanTrackedAreDroppedNotQueued) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const auto r = RunWithin({"run", source, "--config", Config(), "--filter", "none", "--quiet",
                            "--frames", "0:300", "--no-map", "--processes", "--rate", "10", "--out",
                            dir_ + "/out", "--domain", std::to_string(kFasterThanTrackedDomain)},
                           120);
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  std::smatch m;
  ASSERT_TRUE(
      std::regex_search(r.err, m, std::regex("; ([0-9]+) frames dropped \\(arrived faster")))
      << r.err;
  EXPECT_GT(std::stoi(m[1]), 0) << r.err;
  const RealtimeReport report = ReadRealtimeReport(dir_ + "/out/realtime.txt");
  EXPECT_EQ(report.frames, 300u);
  EXPECT_GT(report.dropped(), 0u);
  EXPECT_GE(report.dropped(), static_cast<size_t>(std::stoi(m[1]))) << "slam's drops are the run's";
  // Bounded by the waiting frames (4 at 300 frames/s: 13 ms) and one frame's tracking; the margin
  // is for a loaded machine, far below the queue's seconds.
  EXPECT_LT(report.latency_p99_ms, 1000.0) << r.out;
}

// A frame source already playing on the run's partition (another robot's player, a second run):
// the run must not pass that source's frames off as its own. It exits 3 and says how many
// processed frames are not its own; eval.json is never "complete". Before: exit 0, "160 of 60
// requested frames processed (complete)", the trajectory the other source's.
TEST_F(RunIntegrity, FramesOfAnotherSourceOnThePartitionAreNotThisRuns) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string partition = "dygslam_integrity_rival";
  const pid_t rival =
      testing::SpawnDygslam({"component", "player", "--dataset", source, "--config", Config(),
                             "--frames", "200:360", "--rate", "1", "--window", "0", "--partition",
                             partition, "--domain", std::to_string(kRivalDomain)},
                            dir_ + "/rival.out", dir_ + "/rival.err");
  std::this_thread::sleep_for(std::chrono::seconds(2));
  const auto r = RunWithin({"run", source, "--config", Config(), "--filter", "none", "--quiet",
                            "--frames", "0:60", "--no-map", "--out", dir_ + "/out", "--partition",
                            partition, "--domain", std::to_string(kRivalDomain)},
                           150);
  kill(rival, SIGTERM);
  int code = -1;
  for (int i = 0; i < 200 && !Exited(rival, &code); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  if (code == -1) kill(rival, SIGKILL);
  const std::string json = ReadAll(dir_ + "/out/eval.json");
  if (Contains(json, "\"foreign\": 0,")) {
    // The run's own player won the partition (the rival's frames were all refused): then its
    // frames are exactly its own.
    EXPECT_EQ(r.code, 0) << r.out << r.err;
    EXPECT_TRUE(Contains(r.out, "integrity: 60 of 60 requested frames processed (complete)"))
        << r.out;
  } else {
    EXPECT_EQ(r.code, 3) << r.out << r.err;
    EXPECT_TRUE(Contains(r.err, "of the processed frames are not this run's")) << r.err;
    EXPECT_TRUE(Contains(json, "\"complete\": false")) << json;
    EXPECT_FALSE(Contains(r.out, "(complete)")) << r.out;
  }
}

// --processes: the mapper stopped by a SIGTERM of its own mid-run (an operator's kill, a
// supervisor) flushes a map of the keyframes until then and exits 0. Before, the run then ended
// with every frame tracked, "complete" and exit 0, its map.bt covering part of the run. Now the
// run names the component and exits 3, and eval.json is not complete.
TEST_F(RunIntegrity, AComponentStoppedOnItsOwnIsNotACompleteRun) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string out = dir_ + "/out";
  const pid_t pid = Spawn({"run", source, "--config", Config(), "--filter", "none", "--quiet",
                           "--frames", "0:150", "--processes", "--rate", "1", "--out", out,
                           "--domain", std::to_string(kStoppedDomain)});
  ASSERT_GT(pid, 0);
  // Once the mapper catches SIGTERM (its main() runs) and the frames flow (1 s at 30 Hz).
  const pid_t mapper = RunningComponentPid("mapper", out);
  ASSERT_GT(mapper, 0) << ReadAll(dir_ + "/run.err");
  std::this_thread::sleep_for(std::chrono::seconds(1));
  kill(mapper, SIGTERM);
  std::string diagnostics;
  const int code = testing::WaitForExit(pid, 120, &diagnostics);
  const std::string summary = ReadAll(dir_ + "/run.out"), err = ReadAll(dir_ + "/run.err");
  EXPECT_EQ(code, 3) << summary << err << diagnostics;
  EXPECT_TRUE(Contains(err, "incomplete part: mapper (signal 15)")) << err;
  EXPECT_TRUE(Contains(summary,
                       "a component ended before the run did (stopped by a signal sent "
                       "to it alone"))
      << summary;
  EXPECT_FALSE(Contains(summary, "(complete)")) << summary;
  const std::string json = ReadAll(out + "/eval.json");
  // First the signal; a mapper stopped before it found slam also says that its input ended early.
  EXPECT_TRUE(Contains(json, "\"components_cut_short\": [\"mapper (signal 15)\"")) << json;
  EXPECT_TRUE(Contains(json, "\"complete\": false")) << json;
  EXPECT_TRUE(Contains(json, "\"exit_code\": 3}")) << json;
}

// --processes: the mapper paused (SIGSTOP) while slam finishes the run and leaves. slam holds its
// keyframe messages for a mapper that does not acknowledge them until the DDS lease (20 s) ends
// the match; a mapper continued before gets all of them and the run is complete. Paused longer,
// the mapper's map lacks slam's last keyframes: the mapper names its own pause (not slam) and the
// run is incomplete (exit 3).
TEST_F(RunIntegrity, AMapperPausedWhileSlamFinishesMakesTheRunIncomplete) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string out = dir_ + "/out";
  // Not --quiet: the recorder's progress line says when poses come.
  const pid_t pid = Spawn({"run", source, "--config", Config(), "--filter", "none", "--frames",
                           "0:150", "--processes", "--rate", "1", "--out", out, "--domain",
                           std::to_string(kPausedDomain)});
  ASSERT_GT(pid, 0);
  const pid_t mapper = RunningComponentPid("mapper", out);
  ASSERT_GT(mapper, 0) << ReadAll(dir_ + "/run.err");
  // Once the frames flow (the player plays once the mapper has matched slam and announced READY:
  // an event, not a time, a loaded machine starts slowly), 1 s into the 5 s of frames at 30 Hz.
  ASSERT_TRUE(testing::WaitForText(dir_ + "/run.err", "[run] frame "))
      << ReadAll(dir_ + "/run.err");
  std::this_thread::sleep_for(std::chrono::seconds(1));
  // Paused until slam has sent its last frame's pose (the recorder has written the trajectory)
  // and longer than the lease (slam has then left).
  kill(mapper, SIGSTOP);
  const auto paused = std::chrono::steady_clock::now();
  while ((!fs::exists(out + "/trajectory.txt") ||
          std::chrono::steady_clock::now() < paused + std::chrono::seconds(25)) &&
         std::chrono::steady_clock::now() < paused + std::chrono::seconds(90))
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  kill(mapper, SIGCONT);
  std::string diagnostics;
  const int code = testing::WaitForExit(pid, 120, &diagnostics);
  const std::string summary = ReadAll(dir_ + "/run.out"), err = ReadAll(dir_ + "/run.err");
  EXPECT_EQ(code, 3) << summary << err << diagnostics;
  EXPECT_TRUE(Contains(err, "mapper: this process was stopped (SIGSTOP) and continued")) << err;
  EXPECT_TRUE(Contains(err, "incomplete part: mapper (its input ended early)")) << err;
  EXPECT_FALSE(Contains(summary, "(complete)")) << summary;
  const std::string json = ReadAll(out + "/eval.json");
  EXPECT_TRUE(Contains(json, "\"components_cut_short\": [\"mapper (its input ended early)\"]"))
      << json;
}

// --processes: the mapper paused (SIGSTOP) from its start, before it found slam, until slam has
// left. The player plays without its READY (after waiting for it); the mapper never saw slam
// come or go. Before, it waited for slam for ever after it was continued, and so did the run. The
// runner stops a mapper left alone after slam's end; the mapper says it missed slam's keyframes
// (exit 3, named).
TEST_F(RunIntegrity, AMapperPausedFromItsStartDoesNotHoldTheRunForEver) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string out = dir_ + "/out";
  const pid_t pid = Spawn({"run", source, "--config", Config(), "--filter", "none", "--quiet",
                           "--frames", "0:60", "--processes", "--rate", "1", "--out", out,
                           "--domain", std::to_string(kMapperPausedFromStartDomain)});
  ASSERT_GT(pid, 0);
  const pid_t mapper = RunningComponentPid("mapper", out);
  ASSERT_GT(mapper, 0) << ReadAll(dir_ + "/run.err");
  kill(mapper, SIGSTOP);
  const auto paused = std::chrono::steady_clock::now();
  // Continued once the recorder has written the trajectory (slam is done) and slam has left.
  while (!fs::exists(out + "/trajectory.txt") &&
         std::chrono::steady_clock::now() < paused + std::chrono::seconds(150))
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  std::this_thread::sleep_for(std::chrono::seconds(5));
  kill(mapper, SIGCONT);
  std::string diagnostics;
  const int code = testing::WaitForExit(pid, 60, &diagnostics);
  const std::string summary = ReadAll(dir_ + "/run.out"), err = ReadAll(dir_ + "/run.err");
  EXPECT_EQ(code, 3) << summary << err << diagnostics;
  EXPECT_TRUE(Contains(err, "mapper: slam was never found") ||
              Contains(err, "mapper: this process was stopped (SIGSTOP) and continued"))
      << err;
  EXPECT_TRUE(Contains(err, "incomplete part: mapper (its input ended early)")) << err;
  EXPECT_FALSE(Contains(summary, "(complete)")) << summary;
  EXPECT_TRUE(Contains(ReadAll(out + "/eval.json"),
                       "\"components_cut_short\": [\"mapper (its input ended early)\"]"));
}

// --processes: the detector paused (SIGSTOP) from early in the run to its end. slam carries its
// last boxes forward, then goes geometry-only; at the end the detector does not stop and the
// runner kills it. Before, the run said "complete", exit 0 (also with --deterministic, whose
// output then differs from --direct). The boxes ended early: the run is incomplete (exit 3) and
// names the detector.
TEST_F(RunIntegrity, ADetectorPausedUntilTheEndMakesTheRunIncomplete) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  DYGSLAM_REQUIRE_MODELS(models);
  const std::string out = dir_ + "/out";
  const pid_t pid = Spawn({"run", source, "--config", Config(), "--filter", "full", "--quiet",
                           "--frames", "0:60", "--no-map", "--processes", "--rate", "1", "--out",
                           out, "--domain", std::to_string(kDetectorPausedDomain)});
  ASSERT_GT(pid, 0);
  const pid_t detector = RunningComponentPid("detector", out);
  ASSERT_GT(detector, 0) << ReadAll(dir_ + "/run.err");
  std::this_thread::sleep_for(std::chrono::seconds(1));
  kill(detector, SIGSTOP);
  std::string diagnostics;
  const int code = testing::WaitForExit(pid, 150, &diagnostics);
  kill(detector, SIGCONT);  // if it is still there
  const std::string summary = ReadAll(dir_ + "/run.out"), err = ReadAll(dir_ + "/run.err");
  EXPECT_EQ(code, 3) << summary << err << diagnostics;
  EXPECT_TRUE(Contains(err, "detector (did not stop at the end of the run: killed)")) << err;
  EXPECT_FALSE(Contains(summary, "(complete)")) << summary;
  EXPECT_TRUE(Contains(ReadAll(out + "/eval.json"), "\"complete\": false"))
      << ReadAll(out + "/eval.json");
}

// --processes --rate 1 (12 s of frames): the detector paused (SIGSTOP) for 5 s mid-run, then
// continued. slam stops waiting for its boxes, carries the last ones a few frames, then runs
// geometry-only until the detections come again. Before, every frame had a pose, the run said
// "complete" and exited 0 although a third of the frames had not been filtered as asked ("(detector
// lost)" only in a log line). Those frames are the run's shortfall: incomplete (exit 3), named in
// the summary and in eval.json.
TEST_F(RunIntegrity, FramesRunWithoutTheirBoxesMakeTheRunIncomplete) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  DYGSLAM_REQUIRE_MODELS(models);
  const std::string out = dir_ + "/out";
  const pid_t pid = Spawn({"run", source, "--config", Config(), "--filter", "full", "--quiet",
                           "--no-map", "--processes", "--rate", "1", "--out", out, "--domain",
                           std::to_string(kDetectorLostDomain)});
  ASSERT_GT(pid, 0);
  const pid_t detector = RunningComponentPid("detector", out);
  ASSERT_GT(detector, 0) << ReadAll(dir_ + "/run.err");
  std::this_thread::sleep_for(std::chrono::seconds(1));
  kill(detector, SIGSTOP);
  std::this_thread::sleep_for(std::chrono::seconds(5));
  kill(detector, SIGCONT);
  std::string diagnostics;
  const int code = testing::WaitForExit(pid, 150, &diagnostics);
  const std::string summary = ReadAll(dir_ + "/run.out"), err = ReadAll(dir_ + "/run.err");
  EXPECT_EQ(code, 3) << summary << err << diagnostics;
  // Every frame the pipeline took is tracked (its pose in the trajectory) or counted lost; the
  // others were dropped at the camera's rate (a loaded machine drops many: seen 219 of 360, and
  // of the 141 taken 4 lost over the gaps) and are counted as such: none is missing unexplained.
  const std::string json = ReadAll(out + "/eval.json");
  std::smatch processed, with_pose, lost, dropped;
  ASSERT_TRUE(std::regex_search(json, processed, std::regex(R"("processed": (\d+),)"))) << json;
  ASSERT_TRUE(std::regex_search(json, with_pose, std::regex(R"("with_pose": (\d+),)"))) << json;
  const size_t num_lost =
      std::regex_search(json, lost, std::regex(R"("lost": (\d+))")) ? std::stoul(lost[1]) : 0;
  ASSERT_TRUE(std::regex_search(summary, dropped, std::regex(R"(360 frames, (\d+) dropped)")))
      << summary;
  EXPECT_EQ(ReadTumTrajectory(out + "/trajectory.txt").size(), std::stoul(with_pose[1])) << err;
  EXPECT_EQ(std::stoul(processed[1]), std::stoul(with_pose[1]) + num_lost) << json;
  EXPECT_EQ(std::stoul(processed[1]) + std::stoul(dropped[1]), 360u) << summary;
  EXPECT_TRUE(Contains(err, "detections are arriving again")) << err;
  EXPECT_TRUE(Contains(err,
                       "frames ran without person boxes (geometry-only): the detector was "
                       "lost"))
      << err;
  EXPECT_FALSE(Contains(summary, "(complete)")) << summary;
  EXPECT_TRUE(Contains(json, "\"complete\": false")) << json;
  EXPECT_TRUE(Contains(json, "frames ran without person boxes")) << json;
}

// --out replaced while the run goes (renamed away, a link to a dataset folder put in its place):
// before, the recorder wrote into the dataset and replaced its groundtruth.txt, exit 0 (and with
// --processes the player's realtime.txt went through the link). The folder is pinned when the
// run starts, by every process of it: the outputs go into it where it now is, the run says so,
// and the dataset is untouched.
void RunIntegrity::ExpectOutputFolderReplacedMidRunIsNeverWrittenThrough(
    const std::string& source, int domain, const std::vector<std::string>& extra) {
  const std::string& dir = dir_;
  const std::string data = SmallDataset(source, 90, "data", /*with_groundtruth=*/true);
  std::ofstream(data + "/realtime.txt") << "the user's notes\n";
  const std::string groundtruth = ReadAll(data + "/groundtruth.txt");
  const std::string out = dir + "/out", moved = dir + "/out.moved";
  std::vector<std::string> args = {"run",
                                   data,
                                   "--config",
                                   Config(),
                                   "--filter",
                                   "none",
                                   "--quiet",
                                   "--rate",
                                   "1",
                                   "--out",
                                   out,
                                   "--domain",
                                   std::to_string(domain)};
  args.insert(args.end(), extra.begin(), extra.end());
  const pid_t pid = testing::SpawnDygslam(args, dir + "/run.out", dir + "/run.err");
  ASSERT_GT(pid, 0);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  testing::WaitForText(dir + "/run.err", "DDS partition");
  // Mid-run: every process of the run has checked its files (a component catches SIGTERM once it
  // has) and those that write into the folder have pinned it. A component that starts after the
  // folder was replaced sees the replacement and refuses it before it writes anything.
  if (std::find(extra.begin(), extra.end(), "--processes") != extra.end()) {
    std::error_code ec;
    fs::path folder;
    for (const std::string component : {"recorder", "mapper", "slam", "player"}) {
      const auto ready = [&](pid_t p) {
        return p != 0 && ProcessCatchesSignal(p, SIGTERM) &&
               (component == "slam" || HoldsFolder(p, folder));
      };
      pid_t component_pid = 0;
      while (!ready(component_pid) && std::chrono::steady_clock::now() < deadline) {
        folder = fs::canonical(out, ec);  // the run makes it
        component_pid = ComponentPid(component, out);
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
      }
      ASSERT_TRUE(ready(component_pid)) << component << " did not start or pin " << out << "\n"
                                        << ReadAll(dir + "/run.err");
    }
  }
  std::this_thread::sleep_for(std::chrono::seconds(1));  // of 3 s of frames at 30 Hz
  fs::rename(out, moved);
  fs::create_directory_symlink(data, out);
  std::string diagnostics;
  const int code = testing::WaitForExit(pid, 120, &diagnostics);
  const std::string summary = ReadAll(dir + "/run.out"), err = ReadAll(dir + "/run.err");
  EXPECT_EQ(ReadAll(data + "/groundtruth.txt"), groundtruth) << "the dataset was written into";
  EXPECT_EQ(ReadAll(data + "/realtime.txt"), "the user's notes\n") << "written through the link";
  EXPECT_FALSE(fs::exists(data + "/trajectory.txt"));
  EXPECT_FALSE(fs::exists(data + "/map.bt"));
  EXPECT_TRUE(Contains(err, "the output folder " + out + " was replaced while the command ran"))
      << err;
  EXPECT_TRUE(fs::exists(moved + "/map.bt")) << err;
  EXPECT_TRUE(Contains(ReadAll(moved + "/realtime.txt"), "rate 1\n")) << err;
  EXPECT_EQ(code, 0) << summary << err << diagnostics;
  // Every frame is in the moved folder's trajectory or counted as dropped: a loaded machine may
  // not take every frame at the camera's rate (seen in a parallel suite: 9 of 90 dropped), and
  // those are the only frames allowed to be missing.
  std::smatch dropped;
  ASSERT_TRUE(std::regex_search(summary, dropped, std::regex(R"(90 frames, (\d+) dropped)")))
      << summary;
  const size_t poses = ReadTumTrajectory(moved + "/trajectory.txt").size();
  EXPECT_EQ(poses + std::stoul(dropped[1]), 90u) << summary << err;
  // Worst seen: 81 of 90 with a pose (9 dropped). Floor: 80 %, twice the worst drop.
  EXPECT_GE(poses, 72u) << summary << err;
  if (std::stoul(dropped[1]) == 0) {
    EXPECT_TRUE(Contains(summary, "integrity: 90 of 90 requested frames processed (complete)"))
        << summary;
  } else {
    EXPECT_TRUE(Contains(summary, "integrity: " + std::to_string(poses) +
                                      " of 90 requested frames processed, " + dropped[1].str() +
                                      " missing, 0 not this run's: dropped: "))
        << summary;
  }
  EXPECT_TRUE(Contains(summary, "outputs: " + moved + "/{trajectory.txt")) << summary;
  EXPECT_TRUE(Contains(summary, ",realtime.txt,")) << summary;
}

TEST_F(RunIntegrity, AnOutputFolderReplacedMidRunIsNeverWrittenThrough) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  ExpectOutputFolderReplacedMidRunIsNeverWrittenThrough(source, kSwappedDomain, {});
}

TEST_F(RunIntegrity, AnOutputFolderReplacedMidRunIsNeverWrittenThroughByAnyProcess) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  ExpectOutputFolderReplacedMidRunIsNeverWrittenThrough(source, kSwappedProcessesDomain,
                                                        {"--processes"});
}

int RunIntegrity::RunWithComponentPaused(const std::string& source, const std::string& component,
                                         const std::string& frames, int domain,
                                         std::chrono::seconds after, std::chrono::seconds paused,
                                         std::string* diagnostics) {
  const std::string out = dir_ + "/out";
  const pid_t pid = Spawn({"run", source, "--config", Config(), "--filter", "none", "--quiet",
                           "--frames", frames, "--no-map", "--processes", "--rate", "1", "--out",
                           out, "--domain", std::to_string(domain)});
  if (pid <= 0) {
    ADD_FAILURE() << "run did not start";
    return -1;
  }
  const pid_t target = RunningComponentPid(component, out);
  if (target <= 0) {
    ADD_FAILURE() << component << " not found: " << ReadAll(dir_ + "/run.err");
    kill(pid, SIGKILL);
    testing::WaitForExit(pid, 30, diagnostics);
    return -1;
  }
  std::this_thread::sleep_for(after);  // the frames flow
  kill(target, SIGSTOP);
  std::this_thread::sleep_for(paused);
  kill(target, SIGCONT);
  return testing::WaitForExit(pid, 120, diagnostics);
}

// --processes --rate 1 with the player paused (SIGSTOP) for 5 s: no frame was out while no pose
// came, so the pipeline did not stall: the run is complete (exit 0) and never called stalled.
// Before, the summary said "stalled: no result for 5 s while frames arrived" beside exit 0.
TEST_F(RunIntegrity, APausedPlayerIsNoStallOfThePipeline) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string out = dir_ + "/out";
  std::string diagnostics;
  const int code =
      RunWithComponentPaused(source, "player", "0:150", kPlayerPausedDomain,
                             std::chrono::seconds(2), std::chrono::seconds(5), &diagnostics);
  ASSERT_NE(code, -1);
  const std::string summary = ReadAll(dir_ + "/run.out"), err = ReadAll(dir_ + "/run.err");
  EXPECT_FALSE(Contains(summary, "stalled")) << summary;
  std::smatch m;
  ASSERT_TRUE(std::regex_search(summary, m, std::regex("150 frames, ([0-9]+) dropped"))) << summary;
  if (std::stoi(m[1]) == 0) {
    EXPECT_EQ(code, 0) << summary << err << diagnostics;
    EXPECT_TRUE(Contains(summary, "integrity: 150 of 150 requested frames processed (complete)"))
        << summary;
  }
  const RealtimeReport report = ReadRealtimeReport(out + "/realtime.txt");
  EXPECT_LT(report.longest_gap_s, kStallSeconds) << summary;
}

// --processes --rate 1 with slam paused (SIGSTOP) for 6 s: the frames the player sent meanwhile
// are lost. Before, they counted as dropped by the camera's pace and the run exited 0. A stretch
// without any pose while frames arrive is a stall: the run is incomplete (exit 3) and says so.
TEST_F(RunIntegrity, AStallAtCameraRateIsNotTheCamerasPace) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string out = dir_ + "/out";
  std::string diagnostics;
  const int code =
      RunWithComponentPaused(source, "slam", "0:300", kStallDomain, std::chrono::seconds(3),
                             std::chrono::seconds(6), &diagnostics);
  ASSERT_NE(code, -1);
  const std::string summary = ReadAll(dir_ + "/run.out"), err = ReadAll(dir_ + "/run.err");
  EXPECT_EQ(code, 3) << summary << err << diagnostics;
  EXPECT_TRUE(Contains(summary, "stalled: no result for")) << summary;
  const std::string json = ReadAll(out + "/eval.json");
  EXPECT_TRUE(Contains(json, "\"complete\": false, \"shortfall\": \"the stream was cut")) << json;
}

// The same with slam paused for 2 s (60 frames at 30 Hz): before, the frames lost meanwhile were
// put on the camera's pace and the run exited 0 (a stall counted from 3 s).
TEST_F(RunIntegrity, AShortStallAtCameraRateIsNotTheCamerasPaceEither) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string out = dir_ + "/out";
  std::string diagnostics;
  const int code =
      RunWithComponentPaused(source, "slam", "0:300", kShortStallDomain, std::chrono::seconds(3),
                             std::chrono::seconds(2), &diagnostics);
  ASSERT_NE(code, -1);
  const std::string summary = ReadAll(dir_ + "/run.out"), err = ReadAll(dir_ + "/run.err");
  EXPECT_EQ(code, 3) << summary << err << diagnostics;
  EXPECT_TRUE(Contains(summary, "stalled: no result for")) << summary;
  EXPECT_FALSE(Contains(summary, "(complete)")) << summary;
}

// A looped replay (--loop-minutes 0.25) whose player is stopped after 3 s: before, exit 0
// ("replayed for 0.25 min"). Now the run says it was cut short and exits 3.
TEST_F(RunIntegrity, ALoopedReplayEndedBeforeItsTimeIsNotComplete) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string out = dir_ + "/out";
  const auto start = std::chrono::steady_clock::now();
  const pid_t pid = Spawn({"run", source, "--config", Config(), "--filter", "none", "--quiet",
                           "--frames", "0:30", "--no-map", "--processes", "--loop-minutes", "0.25",
                           "--out", out, "--domain", std::to_string(kLoopDomain)});
  ASSERT_GT(pid, 0);
  const pid_t player = RunningComponentPid("player", out);
  ASSERT_GT(player, 0) << ReadAll(dir_ + "/run.err");
  std::this_thread::sleep_for(std::chrono::seconds(3));
  kill(player, SIGTERM);
  std::string diagnostics;
  const int code = testing::WaitForExit(pid, 120, &diagnostics);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const std::string summary = ReadAll(dir_ + "/run.out"), err = ReadAll(dir_ + "/run.err");
  ASSERT_LT(seconds, 15.0) << "the replay was not cut short: " << summary;
  EXPECT_EQ(code, 3) << summary << err << diagnostics;
  EXPECT_TRUE(Contains(summary, "replayed for 0.25 min): ")) << summary;
  const std::string json = ReadAll(out + "/eval.json");
  EXPECT_TRUE(Contains(json, "\"complete\": false")) << json;
  EXPECT_TRUE(Contains(json, "\"exit_code\": 3}")) << json;
}

}  // namespace
// `run --processes` killed outright (SIGKILL, no chance to stop its components): the components
// end with it. Before, they ran on, finished and wrote over the outputs of the next run into the
// same folder seconds later.
TEST_F(RunIntegrity, TheComponentsOfARunKilledOutrightEndWithIt) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string out = dir_ + "/out";
  const pid_t pid = Spawn({"run", source, "--config", Config(), "--filter", "none", "--quiet",
                           "--frames", "0:300", "--no-map", "--processes", "--rate", "1", "--out",
                           out, "--domain", std::to_string(kKilledRunDomain)});
  ASSERT_GT(pid, 0);
  const pid_t slam = RunningComponentPid("slam", out);
  const pid_t recorder = RunningComponentPid("recorder", out);
  ASSERT_GT(slam, 0) << ReadAll(dir_ + "/run.err");
  ASSERT_GT(recorder, 0) << ReadAll(dir_ + "/run.err");
  std::this_thread::sleep_for(std::chrono::seconds(2));
  kill(pid, SIGKILL);
  int code = -1;
  for (int i = 0; i < 100 && !Exited(pid, &code); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  // Gone (or a zombie of init's) within 3 s.
  const auto alive = [](pid_t p) {
    const std::string stat = ReadAll("/proc/" + std::to_string(p) + "/stat");
    const size_t close = stat.rfind(')');
    return !stat.empty() && close != std::string::npos && close + 2 < stat.size() &&
           stat[close + 2] != 'Z';
  };
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(3);
  while ((alive(slam) || alive(recorder)) && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_FALSE(alive(slam)) << "slam outlived its run";
  EXPECT_FALSE(alive(recorder)) << "the recorder outlived its run";
  EXPECT_FALSE(fs::exists(out + "/trajectory.txt")) << "written after the run was killed";
}

// `run --processes` suspended as a whole (Ctrl-Z of its process group, a laptop asleep) for longer
// than the DDS participant lease (20 s), then continued: each component was paused as long as its
// peers, so none of them is gone; they find each other again and the run completes. Before, every
// component took its peers' expired leases for their end and the run ended with a third of its
// frames, blaming the components (exit 3).
TEST_F(RunIntegrity, ARunSuspendedAsAWholeCompletes) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string out = dir_ + "/out";
  const pid_t pid = Spawn({"run", source, "--config", Config(), "--filter", "none", "--quiet",
                           "--frames", "0:150", "--no-map", "--processes", "--rate", "0.5", "--out",
                           out, "--domain", std::to_string(kSuspendedDomain)});
  ASSERT_GT(pid, 0);
  std::vector<pid_t> group = {pid};
  for (const char* name : {"recorder", "slam", "player"}) {
    group.push_back(RunningComponentPid(name, out));
    ASSERT_GT(group.back(), 0) << name << " did not start\n" << ReadAll(dir_ + "/run.err");
  }
  std::this_thread::sleep_for(std::chrono::seconds(2));  // ~30 frames in
  for (const pid_t p : group) kill(p, SIGSTOP);
  std::this_thread::sleep_for(std::chrono::seconds(24));
  for (const pid_t p : group) kill(p, SIGCONT);
  std::string diagnostics;
  const int code = testing::WaitForExit(pid, 120, &diagnostics);
  const std::string err = ReadAll(dir_ + "/run.err");
  const std::string summary = ReadAll(dir_ + "/run.out");
  EXPECT_EQ(code, 0) << diagnostics << summary << err;
  EXPECT_FALSE(Contains(err, "ended before the run did")) << err;
  // Every frame, but for a few the paced player may drop on a loaded machine (counted as such).
  EXPECT_GE(ReadTumTrajectory(out + "/trajectory.txt").size(), 140u) << summary << err;
  EXPECT_TRUE(Contains(summary, "integrity: 150 of 150 requested frames") ||
              Contains(summary, "dropped: the pipeline could not take them"))
      << summary;
}

}  // namespace dygslam
