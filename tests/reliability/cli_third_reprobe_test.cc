// Third re-probe of issue 20 (2026-12-02), the command-line half: each case failed before its fix.
//   item 1  `map` failing mid-run (an image that does not decode) lost every frame before it
//   item 2  a settings pipe: Ctrl-C / SIGTERM were ignored while waiting (up to the 30 s timeout,
//           or forever when the writer stalls mid-file)
//   item 3  Detector.every_n_frames > 1 was silently not applied in the DDS modes
//   item 5  a groundtruth.txt that is a FIFO, a folder or a link to /dev/zero silently disabled
//           the evaluation
//   item 6  --detections matching no frame was silent
//   item 7  100 kB values of --domain / --listen / --partition were echoed whole
//   item 8  --frames beyond the dataset was cut silently
//   item 13 `run --direct` with no models wrote four empty outputs before failing
//   item 14 a DDS run overwrote a groundtruth.txt of the user's in --out
// The DDS run uses domain 200 (this test's range: 200-204) inside the netns emulator.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "core/base/stop_signal.h"
#include "core/io/dataset.h"
#include "core/io/trajectory_io.h"
#include "tests/support/cli_fixture.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

using testing::Contains;

class CliThirdReprobe : public testing::CliFixture {
 protected:
  CliThirdReprobe() : CliFixture("cli_third_reprobe") {}

  // Replaces rgb.txt entry `entry`'s image by a truncated copy named broken.png.
  void BreakImage(const std::string& dataset, size_t entry) {
    const RgbdDataset d = RgbdDataset::Open(dataset);
    const std::string bytes = testing::ReadAll(d.frame(entry).rgb_path);
    std::ofstream(dataset + "/broken.png", std::ios::binary) << bytes.substr(0, bytes.size() / 3);
    std::string rgb = testing::ReadAll(dataset + "/rgb.txt");
    const std::string old_path = d.frame(entry).rgb_path;
    rgb.replace(rgb.find(old_path), old_path.size(), "broken.png");
    std::ofstream(dataset + "/rgb.txt") << rgb;
  }
};

// Item 1: every output of `map` from the frames before the error, atomically; exit 1.
TEST_F(CliThirdReprobe, MapThatFailsLateWritesEveryOutput) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string dataset = SmallDataset(source, 30, "late");
  BreakImage(dataset, 20);
  const std::string out = dir_ + "/late_map";
  const auto r = Run({"map", dataset, "--config", Config(), "--out", out, "--filter", "none",
                      "--deterministic", "--quiet"});
  ExpectError(r, 1, {"broken.png", "rgb.txt:21", "[map] stopped by an error after 20 frames"});
  for (const char* name :
       {"map.bt", "map.ot", "map_top.png", "map_slice.png", "trajectory.txt", "keyframes.txt"})
    EXPECT_TRUE(fs::is_regular_file(fs::path(out) / name)) << name << "\n" << r.err;
  const auto trajectory = ReadTumTrajectory(out + "/trajectory.txt");
  EXPECT_GE(trajectory.size(), 18u);
  EXPECT_LE(trajectory.size(), 20u);
  for (const auto& e : fs::directory_iterator(out))
    EXPECT_FALSE(Contains(e.path().filename().string(), ".tmp.")) << e.path();
}

// Item 2: a stop signal while the settings pipe is waited for ends the command at once with
// 128 + signal, nothing written (the --out folder it made is removed).
TEST_F(CliThirdReprobe, StopSignalWhileReadingASettingsPipe) {
  const std::string yaml = testing::ReadAll(Config());
  for (const int sig : {SIGINT, SIGTERM}) {
    const std::string fifo = dir_ + "/settings_" + std::to_string(sig) + ".yaml";
    ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
    // SIGTERM: a writer that sends half the file and stalls; SIGINT: no writer at all.
    std::thread writer;
    std::atomic<bool> done{false};
    if (sig == SIGTERM) {
      writer = std::thread([&] {
        int fd = -1;
        for (int k = 0; k < 1000 && fd < 0 && !done; ++k) {
          fd = ::open(fifo.c_str(), O_WRONLY | O_NONBLOCK);
          if (fd < 0) std::this_thread::sleep_for(std::chrono::milliseconds(10));
        }
        if (fd < 0) return;
        (void)!::write(fd, yaml.data(), yaml.size() / 2);
        while (!done) std::this_thread::sleep_for(std::chrono::milliseconds(10));
        ::close(fd);
      });
    }
    const std::string out = dir_ + "/pipe_out_" + std::to_string(sig);
    const pid_t pid = testing::SpawnDygslam({"run", dir_, "--config", fifo, "--out", out},
                                            dir_ + "/pipe.out", dir_ + "/pipe.err");
    for (int k = 0; k < 500 && !ProcessCatchesSignal(pid, sig); ++k)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    std::this_thread::sleep_for(std::chrono::milliseconds(500));  // in the wait by now
    const auto t0 = std::chrono::steady_clock::now();
    ::kill(pid, sig);
    std::string diagnostics;
    const int code = testing::WaitForExit(pid, 10.0, &diagnostics);
    const double took =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    done = true;
    if (writer.joinable()) writer.join();
    const std::string err = testing::ReadAll(dir_ + "/pipe.err") + diagnostics;
    EXPECT_EQ(code, 128 + sig) << err;
    EXPECT_LT(took, 3.0) << err;
    EXPECT_TRUE(Contains(err, fifo)) << err;
    EXPECT_FALSE(fs::exists(out)) << "an empty --out folder left behind";
  }
}

// Items 5 and 8: a groundtruth.txt that is not a regular file warns like a malformed one; a
// --frames beyond the dataset warns naming --frames and the real count.
TEST_F(CliThirdReprobe, NonRegularGroundTruthAndFramesBeyondTheDatasetWarn) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  struct Kind {
    std::string name, reason;
  };
  for (const Kind& kind : std::vector<Kind>{{"fifo", "a FIFO"},
                                            {"folder", "a directory"},
                                            {"zero", "a character device (a link to /dev/zero)"}}) {
    const std::string dataset = SmallDataset(source, 12, "gt_" + kind.name);
    const std::string gt = dataset + "/groundtruth.txt";
    if (kind.name == "fifo") ASSERT_EQ(mkfifo(gt.c_str(), 0600), 0);
    if (kind.name == "folder") fs::create_directories(gt);
    if (kind.name == "zero") fs::create_symlink("/dev/zero", gt);
    const auto r = Run({"run", dataset, "--config", Config(), "--out", dir_ + "/o_" + kind.name,
                        "--filter", "none", "--direct", "--quiet", "--frames", "0:5000"});
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_TRUE(Contains(r.err, "warning: " + gt + ": not a regular file: " + kind.reason))
        << r.err;
    EXPECT_TRUE(Contains(r.err, "without evaluation")) << r.err;
    EXPECT_TRUE(Contains(r.out, "ATE: not evaluated")) << r.out;
    EXPECT_TRUE(Contains(r.err, "warning: --frames '0:5000'")) << r.err;
    EXPECT_TRUE(Contains(r.err, "12 rgb.txt entries")) << r.err;
  }
}

// Item 6: a detections file that matches no frame warns with the counts; a class id outside the
// detector's classes is an error with file:line.
TEST_F(CliThirdReprobe, DetectionsThatMatchNoFrameWarnAndBadClassIdsFail) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  DYGSLAM_REQUIRE_MODELS(models);
  const std::string dataset = SmallDataset(source, 10, "det");
  const std::string det = dir_ + "/det.txt";
  std::ofstream(det) << "99.0 10 10 50 50 0 0.9\n99.1 10 10 50 50 0 0.9\n";
  const auto r = Run({"run", dataset, "--config", Config(), "--out", dir_ + "/o_det", "--filter",
                      "boxes", "--quiet", "--detections", det});
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(Contains(
      r.err, "warning: --detections " + det + ": 2 of its 2 stamps match no frame of the dataset"))
      << r.err;
  EXPECT_TRUE(Contains(r.err, "0 of the run's 10 frames have boxes")) << r.err;
  const RgbdDataset d = RgbdDataset::Open(dataset);
  std::ofstream(det) << d.frame(0).rgb_stamp.ToString() << " 10 10 50 50 0 0.9\n"
                     << d.frame(1).rgb_stamp.ToString() << " 10 10 50 50 999 0.9\n";
  ExpectError(Run({"run", dataset, "--config", Config(), "--out", dir_ + "/o_det2", "--filter",
                   "boxes", "--quiet", "--detections", det}),
              1, {det + ":2", "class_id 999", "0..79"});
  EXPECT_FALSE(fs::exists(dir_ + "/o_det2"));
}

// Item 7: megabyte-long option values are echoed bounded.
TEST_F(CliThirdReprobe, LongOptionValuesAreEchoedBounded) {
  const std::string huge(100000, '7');
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"run", dir_, "--config", Config(), "--out", dir_ + "/o",
                                 "--domain", huge},
        std::vector<std::string>{"run", dir_, "--config", Config(), "--out", dir_ + "/o",
                                 "--loop-minutes", huge + "x"},
        std::vector<std::string>{"discovery-server", "--listen", huge},
        std::vector<std::string>{"discovery-server", "--listen", "127.0.0.1:7400", "--domain",
                                 huge + "x"}}) {
    const auto r = Run(args);
    EXPECT_EQ(r.code, 2) << r.err.substr(0, 500);
    EXPECT_LT(r.err.size(), 3000u) << args[0] << " " << args[args.size() - 2];
    EXPECT_TRUE(Contains(r.err, "(100000 bytes)") || Contains(r.err, "(100001 bytes)"))
        << r.err.substr(0, 800);
  }
}

// Item 13: no models: the run fails before writing anything (it wrote four empty outputs).
TEST_F(CliThirdReprobe, NoModelsFailsBeforeAnyOutput) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string dataset = SmallDataset(source, 5, "nomodels");
  const std::string no_models = dir_ + "/no_models";
  fs::create_directories(no_models);
  ::setenv("DYGSLAM_MODELS_DIR", no_models.c_str(), 1);
  const auto run =
      Run({"run", dataset, "--config", Config(), "--out", dir_ + "/o_run", "--direct", "--quiet"});
  const auto map = Run({"map", dataset, "--config", Config(), "--out", dir_ + "/o_map", "--quiet"});
  ::unsetenv("DYGSLAM_MODELS_DIR");
  for (const auto* r : {&run, &map}) ExpectError(*r, 1, {"yolo-fastest-1.1"});
  EXPECT_FALSE(fs::exists(dir_ + "/o_run")) << run.err;
  EXPECT_FALSE(fs::exists(dir_ + "/o_map")) << map.err;
}

// Items 3, 14 and 7 in the DDS mode (domain 200): the cadence is applied in the DDS modes (no
// "not applied" warning any more; dds/Cadence checks the trajectories), a user's groundtruth.txt
// in --out kept, a long --partition echoed bounded in the banner.
TEST_F(CliThirdReprobe, DdsRunAppliesTheCadenceAndKeepsTheUsersGroundTruth) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  DYGSLAM_REQUIRE_MODELS(models);
  const std::string dataset = SmallDataset(source, 10, "dds", /*with_groundtruth=*/true);
  const std::string settings = dir_ + "/every3.yaml";
  {
    // The preset's own Detector.every_n_frames line is replaced (a key given twice is an error).
    std::istringstream preset(testing::ReadAll(Config()));
    std::ofstream out(settings);
    for (std::string line; std::getline(preset, line);)
      if (line.rfind("Detector.every_n_frames", 0) != 0) out << line << "\n";
    out << "Detector:\n  every_n_frames: 3\n";
  }
  const std::string out = dir_ + "/o_dds";
  fs::create_directories(out);
  const std::string mine = "# my own ground truth, not the dataset's\n1 0 0 0 0 0 0 1\n";
  std::ofstream(out + "/groundtruth.txt") << mine;
  const std::string partition(1000, 'p');
  const auto r = Run({"run", dataset, "--config", settings, "--out", out, "--quiet", "--domain",
                      "200", "--partition", partition});
  EXPECT_EQ(r.code, 0) << r.err.substr(0, 4000);
  EXPECT_FALSE(Contains(r.err, "every_n_frames")) << r.err.substr(0, 4000);
  EXPECT_EQ(testing::ReadAll(out + "/groundtruth.txt"), mine);
  EXPECT_TRUE(Contains(r.err, "was there before this run")) << r.err.substr(0, 4000);
  EXPECT_GE(ReadTumTrajectory(out + "/trajectory.txt").size(), 8u);
  const size_t banner = r.err.find("[run] DDS partition");
  ASSERT_NE(banner, std::string::npos) << r.err.substr(0, 2000);
  EXPECT_LT(r.err.find('\n', banner) - banner, 600u);
  EXPECT_TRUE(Contains(r.err, "(1000 bytes)")) << r.err.substr(0, 1000);
}

}  // namespace
}  // namespace dygslam
