// Faults in the DDS pipeline (the dygslam binary, one process per component, private network
// namespace): a killed mapper restarted mid-run gets the keyframe history back (transient-local,
// the newest 64 messages); a killed detector makes slam go geometry-only and, restarted, is used
// again; SIGINT / SIGTERM at any time leave complete, loadable trajectory and map files.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include "core/base/error.h"
#include "core/base/stop_signal.h"
#include "core/io/trajectory_io.h"
#include "tests/support/cli_fixture.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

using testing::Contains;
using testing::ReadAll;

std::string Config() { return std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/bonn.yaml"; }

// `dygslam ARGS` with stderr (where the components log) in `log`, stdout beside it.
pid_t Spawn(const std::vector<std::string>& args, const std::string& log) {
  return testing::SpawnDygslam(args, log + ".out", log);
}

// First integer captured by `pattern` in `text`, -1 if absent.
long Extract(const std::string& text, const std::string& pattern) {
  std::smatch m;
  if (!std::regex_search(text, m, std::regex(pattern))) return -1;
  return std::stol(m[1]);
}

class Faults : public ::testing::Test {
 protected:
  void SetUp() override {
    DYGSLAM_REQUIRE_DATASET(dir, "bonn_crowd_part");
    dataset_ = dir;
    DYGSLAM_REQUIRE_FILE(testing::DygslamBinary(), "dygslam binary");
  }
  pid_t Run(const std::string& component, const std::string& tmp, int domain,
            const std::string& frames, const std::vector<std::string>& extra = {},
            const std::string& log_name = "") {
    std::vector<std::string> args = {"component", component, "--dataset", dataset_,
                                     "--config",  Config(),  "--out",     tmp + "/out",
                                     "--frames",  frames,    "--domain",  std::to_string(domain)};
    args.insert(args.end(), extra.begin(), extra.end());
    const pid_t pid = Spawn(args, tmp + "/" + (log_name.empty() ? component : log_name) + ".log");
    running_.push_back(pid);
    return pid;
  }
  // A test that stops early (a failed ASSERT) leaves no component running behind it.
  void TearDown() override {
    for (const pid_t pid : running_) {
      if (::kill(pid, SIGKILL) == 0) ::waitpid(pid, nullptr, 0);
    }
  }
  // Exit code of child `pid`; a child that has not exited within `timeout_s` is a hang: the test
  // fails naming it, with its threads' stacks, instead of running into ctest's timeout silently.
  int Wait(pid_t pid, double timeout_s = 60.0) {
    std::string hang;
    const int code = testing::WaitForExit(pid, timeout_s, &hang);
    running_.erase(std::remove(running_.begin(), running_.end(), pid), running_.end());
    if (code < 0) ADD_FAILURE() << hang;
    return code;
  }
  std::string dataset_;
  std::vector<pid_t> running_;
};

TEST_F(Faults, MapperKilledAndRestartedGetsKeyframeHistoryBack) {
  const std::string tmp = testing::MakeTempDir("fault_mapper");
  const int domain = 121;
  // 20 s of frames at --rate 0.5: slam must still be there when the second mapper has started and
  // discovered it (a mapper that never meets slam waits for it, as a hand-started one should), also
  // when a loaded machine takes seconds to produce the first map.
  const std::string frames = "0:300";
  const pid_t recorder = Run("recorder", tmp, domain, frames);
  const pid_t mapper1 = Run("mapper", tmp, domain, frames, {}, "mapper1");
  const pid_t slam = Run("slam", tmp, domain, frames, {"--filter", "none"});
  const pid_t player = Run("player", tmp, domain, frames, {"--rate", "0.5", "--no-detector"});
  // Kill the first mapper once it has received keyframes and written a map from them (an event,
  // not a time: under load the pipeline may take seconds to start).
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (!fs::exists(tmp + "/out/map.bt") && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  const bool first_map = fs::exists(tmp + "/out/map.bt");
  kill(mapper1, SIGKILL);
  EXPECT_EQ(Wait(mapper1), 128 + SIGKILL);
  ASSERT_TRUE(first_map) << "the first mapper never wrote a map\n" << ReadAll(tmp + "/mapper1.log");
  fs::remove(tmp + "/out/map.bt");
  const pid_t mapper2 = Run("mapper", tmp, domain, frames, {}, "mapper2");
  EXPECT_EQ(Wait(player), 0) << ReadAll(tmp + "/player.log");
  EXPECT_EQ(Wait(slam), 0) << ReadAll(tmp + "/slam.log");
  EXPECT_EQ(Wait(recorder), 0) << ReadAll(tmp + "/recorder.log");
  // The restarted mapper is a late joiner: when slam's end of run does not reach it (late-joiner
  // discovery under load), it writes its map once slam has gone and exits 3 (cut short), saying
  // so; when it met slam after more than the history's 64 messages were published (a loaded
  // machine starts it seconds late), the older ones never reach it: it counts them and exits 3;
  // else 0.
  const int mapper2_code = Wait(mapper2);
  const std::string mapper_log = ReadAll(tmp + "/mapper2.log");
  EXPECT_TRUE(mapper2_code == 0 ||
              (mapper2_code == 3 &&
               (mapper_log.find("without announcing the end") != std::string::npos ||
                mapper_log.find("never arrived (they left slam's history") != std::string::npos)))
      << "exit " << mapper2_code << "\n"
      << mapper_log;
  const long in_map = Extract(mapper_log, R"((\d+) keyframes in the map)");
  const auto keyframes = ReadTumTrajectory(tmp + "/out/keyframes.txt");
  ASSERT_GT(keyframes.size(), 3u);
  // The restarted mapper holds keyframes made before it started (from the transient-local
  // history, bounded to the newest 64 messages) and those made after.
  EXPECT_GE(in_map, 1) << mapper_log;
  const long published = Extract(ReadAll(tmp + "/slam.log"), R"((\d+) keyframe messages)");
  const long received = Extract(mapper_log, R"(mapper: (\d+) keyframe messages \()");
  EXPECT_GE(received, std::min(published, 64L)) << mapper_log;  // 64: kKeyframeHistoryDepth
  EXPECT_LE(in_map, static_cast<long>(keyframes.size())) << mapper_log;
  ASSERT_TRUE(fs::exists(tmp + "/out/map.bt")) << "the restarted mapper wrote no map\n"
                                               << mapper_log;
  EXPECT_GT(fs::file_size(tmp + "/out/map.bt"), 1000u);
}

// slam dies (SIGKILL: no COMPONENT_DONE is ever sent): the mapper does not wait forever; once
// slam's keyframe writer is gone (participant lease) and stays gone for writer_gone_s it writes
// the map with what it received and exits 3 (its map may lack slam's last keyframes: a run cut
// short, never 0), saying why.
TEST_F(Faults, MapperEndsWhenSlamDiesWithoutAnnouncingTheEnd) {
  const std::string tmp = testing::MakeTempDir("fault_slam_gone");
  const int domain = 124;
  const pid_t mapper = Run("mapper", tmp, domain, "0:300");
  const pid_t slam = Run("slam", tmp, domain, "0:300", {"--filter", "none"});
  const pid_t player = Run("player", tmp, domain, "0:300", {"--rate", "1", "--no-detector"});
  // Let slam make keyframes, then kill it.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (!fs::exists(tmp + "/out/map.bt") && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  ASSERT_TRUE(fs::exists(tmp + "/out/map.bt")) << "mapper never wrote a map\n"
                                               << ReadAll(tmp + "/mapper.log");
  kill(slam, SIGKILL);
  EXPECT_EQ(Wait(slam), 128 + SIGKILL);
  kill(player, SIGINT);
  Wait(player);
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(Wait(mapper), 3) << ReadAll(tmp + "/mapper.log");  // kExitComponentCutShort
  const double waited =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const std::string log = ReadAll(tmp + "/mapper.log");
  EXPECT_NE(log.find("without announcing the end"), std::string::npos) << log;
  EXPECT_LT(waited, 60.0) << "participant lease (20 s) + writer_gone_s (10 s) should bound it";
  EXPECT_GT(Extract(log, R"((\d+) keyframes in the map)"), 0) << log;
}

// slam dies (SIGKILL, no COMPONENT_DONE): the recorder and the player do not wait for ever either;
// once slam's writers are gone (participant lease) and stay gone for 5 s, the recorder writes the
// poses that came and the player ends, both with exit 3 (cut short: most frames have no pose; the
// player is the command a user watches when the components run on several hosts), and both say
// why.
TEST_F(Faults, RecorderAndPlayerEndWhenSlamDiesWithoutAnnouncingTheEnd) {
  const std::string tmp = testing::MakeTempDir("fault_slam_gone_recorder");
  const int domain = 132;
  const pid_t recorder = Run("recorder", tmp, domain, "0:300");
  const pid_t slam = Run("slam", tmp, domain, "0:300", {"--filter", "none"});
  const pid_t player = Run("player", tmp, domain, "0:300", {"--rate", "1", "--no-detector"});
  std::this_thread::sleep_for(std::chrono::seconds(5));  // ~150 frames at 30 Hz
  kill(slam, SIGKILL);
  EXPECT_EQ(Wait(slam), 128 + SIGKILL);
  EXPECT_EQ(Wait(player), 3) << ReadAll(tmp + "/player.log");      // kExitComponentCutShort
  EXPECT_EQ(Wait(recorder), 3) << ReadAll(tmp + "/recorder.log");  // kExitComponentCutShort
  EXPECT_NE(ReadAll(tmp + "/player.log").find("slam left without announcing"), std::string::npos)
      << ReadAll(tmp + "/player.log");
  const std::string log = ReadAll(tmp + "/recorder.log");
  EXPECT_NE(log.find("slam left without announcing"), std::string::npos) << log;
  const size_t poses = ReadTumTrajectory(tmp + "/out/trajectory.txt").size();
  EXPECT_GT(poses, 10u) << log;
  EXPECT_LT(poses, 300u) << log;
}

// slam stopped by SIGTERM alone mid-stream: it finishes cleanly (final trajectory, COMPONENT_DONE)
// and says that it stopped before the end of the stream; the player and the recorder exit 3 and
// name slam's stop. Before, the player exited 0 (it had published its frames) and the recorder
// blamed the frame source.
TEST_F(Faults, RecorderAndPlayerSayWhenSlamIsStoppedBeforeTheEnd) {
  const std::string tmp = testing::MakeTempDir("fault_slam_stopped");
  const int domain = 137;
  const pid_t recorder = Run("recorder", tmp, domain, "0:300");
  const pid_t slam = Run("slam", tmp, domain, "0:300", {"--filter", "none"});
  const pid_t player = Run("player", tmp, domain, "0:300", {"--rate", "1", "--no-detector"});
  std::this_thread::sleep_for(std::chrono::seconds(5));  // ~150 frames at 30 Hz
  kill(slam, SIGTERM);
  EXPECT_EQ(Wait(slam), 0) << ReadAll(tmp + "/slam.log");
  EXPECT_EQ(Wait(player), 3) << ReadAll(tmp + "/player.log");      // kExitComponentCutShort
  EXPECT_EQ(Wait(recorder), 3) << ReadAll(tmp + "/recorder.log");  // kExitComponentCutShort
  EXPECT_TRUE(Contains(ReadAll(tmp + "/player.log"),
                       "slam stopped by signal 15 before the end of the stream"))
      << ReadAll(tmp + "/player.log");
  EXPECT_TRUE(Contains(ReadAll(tmp + "/recorder.log"),
                       "slam stopped by signal 15 before the end of the stream"))
      << ReadAll(tmp + "/recorder.log");
  const size_t poses = ReadTumTrajectory(tmp + "/out/trajectory.txt").size();
  EXPECT_GT(poses, 10u);
  EXPECT_LT(poses, 300u);
  // The player stops sending once slam said it stopped: the rest would go to nobody. Before, it
  // waited 30 s for each frame's acknowledgement when it had not yet seen slam's pose writer
  // matched, and then sent all 300 frames.
  const long published = Extract(ReadAll(tmp + "/player.log"), R"(published (\d+) frames)");
  EXPECT_GT(published, 0) << ReadAll(tmp + "/player.log");
  EXPECT_LT(published, 300) << ReadAll(tmp + "/player.log");
}

// Components started by hand, the recorder stopped (SIGTERM) and the mapper killed (SIGKILL)
// mid-stream: the trajectory ends where the recorder stopped, the map where the mapper was
// killed. The player, the command a user watches, waits for the recorder's and the mapper's DONE
// after slam's: the recorder's says it was stopped before the end, the mapper left without one;
// the player exits 3 naming each. Before, player and slam exited 0.
TEST_F(Faults, PlayerSaysWhenTheRecorderAndTheMapperEndEarly) {
  const std::string tmp = testing::MakeTempDir("fault_recorder_killed");
  const int domain = 138;
  const pid_t recorder = Run("recorder", tmp, domain, "0:300");
  const pid_t mapper = Run("mapper", tmp, domain, "0:300");
  const pid_t slam = Run("slam", tmp, domain, "0:300", {"--filter", "none"});
  const pid_t player = Run("player", tmp, domain, "0:300",
                           {"--rate", "1", "--wait-for-components", "--no-detector"});
  std::this_thread::sleep_for(std::chrono::seconds(4));
  kill(recorder, SIGTERM);
  kill(mapper, SIGKILL);
  Wait(recorder);
  EXPECT_EQ(Wait(mapper), 128 + SIGKILL);
  EXPECT_EQ(Wait(player), 3) << ReadAll(tmp + "/player.log");  // kExitComponentCutShort
  Wait(slam);
  const std::string log = ReadAll(tmp + "/player.log");
  EXPECT_TRUE(Contains(log, "the recorder stopped by signal 15 before the end of the run")) << log;
  EXPECT_TRUE(Contains(log, "the mapper left without announcing that it is done")) << log;
}

// The player dies (SIGKILL: no END_OF_STREAM): slam and the detector do not wait for the rest of
// the stream for ever; once the frame writer is gone and nothing came for 5 s slam finishes with
// the frames it got (final trajectory to the recorder, COMPONENT_DONE) and the detector ends. The
// stream was cut short: slam exits 3 (its outputs are written, the run is incomplete), and so do
// the recorder and the mapper (they write what came); the detector exits 0.
TEST_F(Faults, SlamEndsWhenThePlayerDiesWithoutAnnouncingTheEnd) {
  const std::string tmp = testing::MakeTempDir("fault_player_gone");
  const int domain = 133;
  const pid_t recorder = Run("recorder", tmp, domain, "0:300");
  const pid_t mapper = Run("mapper", tmp, domain, "0:300");
  const pid_t slam = Run("slam", tmp, domain, "0:300", {"--filter", "none"});
  const pid_t detector = Run("detector", tmp, domain, "0:300");
  const pid_t player = Run("player", tmp, domain, "0:300", {"--rate", "1"});
  std::this_thread::sleep_for(std::chrono::seconds(5));
  kill(player, SIGKILL);
  EXPECT_EQ(Wait(player), 128 + SIGKILL);
  EXPECT_EQ(Wait(slam), 3) << ReadAll(tmp + "/slam.log");  // 3: cut short
  EXPECT_EQ(Wait(detector), 0) << ReadAll(tmp + "/detector.log");
  EXPECT_NE(ReadAll(tmp + "/detector.log").find("frame source left without announcing"),
            std::string::npos)
      << ReadAll(tmp + "/detector.log");
  // The recorder and the mapper write what came, and say that the stream was cut short (3).
  EXPECT_EQ(Wait(recorder), 3) << ReadAll(tmp + "/recorder.log");
  EXPECT_EQ(Wait(mapper), 3) << ReadAll(tmp + "/mapper.log");
  for (const char* name : {"recorder", "mapper"}) {
    const std::string component_log = ReadAll(tmp + "/" + name + ".log");
    EXPECT_NE(component_log.find("never announced the end of its stream"), std::string::npos)
        << component_log;
  }
  EXPECT_TRUE(fs::exists(tmp + "/out/map.bt"));
  const std::string log = ReadAll(tmp + "/slam.log");
  EXPECT_NE(log.find("frame source left without announcing"), std::string::npos) << log;
  const long frames = Extract(log, R"(slam: (\d+) frames)");
  EXPECT_GT(frames, 10) << log;
  EXPECT_LT(frames, 300) << log;
  // The recorder got slam's final trajectory: one pose per processed frame.
  EXPECT_NE(ReadAll(tmp + "/recorder.log").find("(final trajectory)"), std::string::npos)
      << ReadAll(tmp + "/recorder.log");
  EXPECT_EQ(static_cast<long>(ReadTumTrajectory(tmp + "/out/trajectory.txt").size()), frames);
}

TEST_F(Faults, DetectorKilledAndRestartedIsUsedAgain) {
  const std::string tmp = testing::MakeTempDir("fault_detector");
  const int domain = 122;
  const std::vector<std::string> wait = {"--detection-wait-ms", "100"};
  const pid_t recorder = Run("recorder", tmp, domain, "0:300");
  const pid_t slam = Run("slam", tmp, domain, "0:300", wait);
  const pid_t detector1 = Run("detector", tmp, domain, "0:300", {}, "detector1");
  // 20 s of frames (half the real rate): the restarted detector has ~17 s to come up and take
  // frames even when a loaded machine makes its start slow (at --rate 1 it once got none).
  const pid_t player = Run("player", tmp, domain, "0:300", {"--rate", "0.5"});
  std::this_thread::sleep_for(std::chrono::milliseconds(2500));
  kill(detector1, SIGKILL);
  EXPECT_EQ(Wait(detector1), 128 + SIGKILL);
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  const pid_t detector2 = Run("detector", tmp, domain, "0:300", {}, "detector2");
  EXPECT_EQ(Wait(player), 0) << ReadAll(tmp + "/player.log");
  const int slam_code = Wait(slam);
  EXPECT_EQ(Wait(recorder), 0) << ReadAll(tmp + "/recorder.log");
  kill(detector2, SIGINT);
  Wait(detector2);
  const std::string slam_log = ReadAll(tmp + "/slam.log");
  // Frames that ran without any boxes while the detector was down (once the carried boxes were
  // too old) make slam's part incomplete (exit 3, said); the restart may also come in time for
  // the carried boxes to cover the gap (exit 0).
  const long geometry_only = Extract(slam_log, R"(carried forward, (\d+) geometry-only\))");
  EXPECT_EQ(slam_code, geometry_only > 0 ? 3 : 0) << slam_log;
  if (geometry_only > 0)
    EXPECT_NE(slam_log.find(std::to_string(geometry_only) +
                            " frames ran without person boxes (geometry-only)"),
              std::string::npos)
        << slam_log;
  const std::string det_log = ReadAll(tmp + "/detector2.log");
  const long paired = Extract(slam_log, R"(detections: (\d+) paired)");
  const long missing = Extract(slam_log, R"((\d+) missing)");
  const long detector2_frames = Extract(det_log, R"(detector: (\d+) frames)");
  // Every frame reached slam: tracked, or dropped because a loaded machine could not track it
  // at the camera's pace (slam keeps a bounded queue, as a camera driver does).
  const long processed = Extract(slam_log, R"(slam: (\d+) frames \()");
  const long dropped = Extract(slam_log, R"((\d+) frames dropped \(arrived faster than tracked\))");
  EXPECT_EQ(processed + dropped, 300) << slam_log;
  // At half the camera's rate no frame was dropped in any run seen; 5 % allowed for a loaded
  // machine (the check below on the trajectory, > 280 poses, holds with it).
  EXPECT_LE(dropped, 15) << slam_log;
  EXPECT_GT(missing, 0) << "no geometry-only frames while the detector was down\n" << slam_log;
  ASSERT_GT(detector2_frames, 20) << det_log;
  // slam reports both transitions, and detections of the restarted detector were paired again
  // (slam did not stay geometry-only; under load some still miss the wait window).
  EXPECT_NE(slam_log.find("geometry-only"), std::string::npos) << slam_log;
  EXPECT_NE(slam_log.find("arriving again"), std::string::npos) << slam_log;
  // Event-based, not a share of detector2's frames (how many of those miss slam's 100 ms window
  // depends on the load of the cores): the player sends at most 30 frames/s, so detector1 (killed
  // 2.5 s after start) can have supplied at most 75 paired detections; more than 75 + 10 means at
  // least 10 detections of the restarted detector were paired.
  EXPECT_GE(paired, 85) << slam_log << det_log;
  EXPECT_GT(ReadTumTrajectory(tmp + "/out/trajectory.txt").size(), 280u);
}

// A detector that fails at start (model files that are no network: the run's check before
// starting finds the files, the detector cannot load them) in `dygslam run --processes
// --deterministic`: it announces FAILED and slam stops waiting for its detections
// (geometry-only) instead of waiting for them forever (before: the run hung). Every frame has a
// pose, but none was filtered with boxes as the run asked: the run is incomplete (exit 3) and
// says why.
TEST_F(Faults, DetectorFailingAtStartDoesNotHangADeterministicRun) {
  const std::string tmp = testing::MakeTempDir("fault_detector_fails");
  const std::string no_models = tmp + "/broken_models";
  fs::create_directories(no_models + "/yolo-fastest-1.1_coco");
  for (const char* name : {"yolo-fastest-1.1.cfg", "yolo-fastest-1.1.weights", "coco.names"})
    std::ofstream(no_models + "/yolo-fastest-1.1_coco/" + name) << "not a model\n";
  const std::vector<std::string> args = {
      "run",      dataset_,   "--config", Config(), "--out",           tmp + "/out",
      "--frames", "0:30",     "--filter", "full",   "--deterministic", "--processes",
      "--quiet",  "--domain", "125"};
  ::setenv("DYGSLAM_MODELS_DIR", no_models.c_str(), 1);
  const pid_t run = Spawn(args, tmp + "/run.log");
  ::unsetenv("DYGSLAM_MODELS_DIR");
  const int code = Wait(run, 90.0);
  const std::string log = ReadAll(tmp + "/run.log");
  EXPECT_EQ(code, 3) << "a failed detector does not stop the run; it is incomplete\n" << log;
  EXPECT_NE(log.find("slam: the detector failed"), std::string::npos) << log;
  EXPECT_NE(log.find("frames ran without person boxes (geometry-only): the detector failed"),
            std::string::npos)
      << log;
  EXPECT_NE(log.find("slam: 30 frames"), std::string::npos) << log;
  EXPECT_GT(ReadTumTrajectory(tmp + "/out/trajectory.txt").size(), 20u) << log;
}

// Missing detector model files in a DDS run: the run fails before it starts any component
// (exit 1 naming the file), as --direct does. Before, the detector component failed before it
// announced itself and a deterministic slam waited 30 s for the boxes of every frame.
TEST_F(Faults, MissingDetectorModelFailsADdsRunBeforeItStarts) {
  const std::string tmp = testing::MakeTempDir("fault_detector_missing");
  const std::string no_models = tmp + "/no_models";
  fs::create_directories(no_models);
  const std::vector<std::string> args = {
      "run",      dataset_,   "--config", Config(), "--out",           tmp + "/out",
      "--frames", "0:30",     "--filter", "full",   "--deterministic", "--processes",
      "--quiet",  "--domain", "126"};
  ::setenv("DYGSLAM_MODELS_DIR", no_models.c_str(), 1);
  const pid_t run = Spawn(args, tmp + "/run.log");
  ::unsetenv("DYGSLAM_MODELS_DIR");
  EXPECT_EQ(Wait(run, 30.0), 1);
  const std::string log = ReadAll(tmp + "/run.log");
  EXPECT_TRUE(Contains(log, "detector model cfg file not found")) << log;
  EXPECT_FALSE(Contains(log, "started component")) << log;
  EXPECT_FALSE(fs::exists(tmp + "/out/trajectory.txt"));
}

// True once process PID catches `sig` (its handler is installed), within 20 s.
bool WaitUntilCatches(pid_t pid, int sig) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (std::chrono::steady_clock::now() < deadline) {
    if (ProcessCatchesSignal(pid, sig)) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return false;
}

// SIGINT / SIGTERM at several moments (start-up, mid-run, late) into `dygslam run` in each mode
// (DDS threads, DDS processes, direct): it exits 0 with every output complete and loadable
// (trajectory files parse, map.bt is an OctoMap file) and no temporary file left behind.
TEST_F(Faults, StopSignalAtAnyTimeLeavesLoadableOutputs) {
  struct Case {
    std::string mode;
    int signal;
    int after_ms;
  };
  const std::vector<Case> cases = {{"", SIGTERM, 0},
                                   {"", SIGINT, 300},
                                   {"", SIGTERM, 2500},
                                   {"--processes", SIGINT, 2500},
                                   {"--processes", SIGTERM, 0},
                                   {"--direct", SIGINT, 0},
                                   {"--direct", SIGINT, 400},
                                   {"--direct", SIGTERM, 3000}};
  int domain = 123;
  for (const Case& c : cases) {
    SCOPED_TRACE("mode '" + c.mode + "' signal " + std::to_string(c.signal) + " after " +
                 std::to_string(c.after_ms) + " ms");
    const std::string tmp = testing::MakeTempDir("fault_signal");
    std::vector<std::string> args = {"run",
                                     dataset_,
                                     "--config",
                                     Config(),
                                     "--out",
                                     tmp + "/out",
                                     "--frames",
                                     "0:300",
                                     "--filter",
                                     "geometry",
                                     "--quiet",
                                     "--domain",
                                     std::to_string(domain++)};
    if (!c.mode.empty()) args.push_back(c.mode);
    const pid_t run = Spawn(args, tmp + "/run.log");
    // Count from the moment the process catches the signal (dygslam's main installs the handler
    // first thing): before that, exec and dynamic loading would end it like any program.
    EXPECT_TRUE(WaitUntilCatches(run, c.signal)) << "dygslam run never installed a handler";
    if (c.mode != "--direct" && c.after_ms >= 2000) {
      // Mid-run in the DDS modes: once the mapper wrote a first map (slam tracked frames and
      // made keyframes): an event, not a time; on a loaded machine starting the components alone
      // can take longer than 2.5 s (measured: load average 29 on the 2 cores, no frame published
      // after 2.5 s, with this branch and the base alike).
      const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(60);
      while (!fs::exists(tmp + "/out/map.bt") && std::chrono::steady_clock::now() < until) {
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      }
    } else {
      std::this_thread::sleep_for(std::chrono::milliseconds(c.after_ms));
    }
    kill(run, c.signal);
    const auto t0 = std::chrono::steady_clock::now();
    const int status = Wait(run);
    const double stop_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const std::string log = ReadAll(tmp + "/run.log");
    EXPECT_EQ(status, 0) << log;
    EXPECT_LT(stop_s, 30.0) << "stopping took too long";
    ASSERT_TRUE(fs::exists(tmp + "/out")) << log;
    for (const auto& e : fs::recursive_directory_iterator(tmp + "/out")) {
      EXPECT_EQ(e.path().string().find(".tmp"), std::string::npos) << "left behind: " << e.path();
    }
    for (const char* name : {"trajectory.txt", "keyframes.txt"}) {
      const std::string path = tmp + "/out/" + name;
      EXPECT_TRUE(fs::exists(path)) << name << " missing\n" << log;
      if (fs::exists(path)) {
        EXPECT_NO_THROW(ReadTumTrajectory(path)) << path;
      }
    }
    if (c.after_ms >= 2000) {
      EXPECT_GT(ReadTumTrajectory(tmp + "/out/trajectory.txt").size(), 5u) << log;
    }
    if (fs::exists(tmp + "/out/map.bt")) {
      const std::string bt = ReadAll(tmp + "/out/map.bt");
      EXPECT_EQ(bt.rfind("# Octomap OcTree binary file", 0), 0u) << "map.bt is not an OctoMap file";
    }
  }
}

}  // namespace
}  // namespace dygslam
