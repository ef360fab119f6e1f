// The command line, re-probe of issue 20 (2026-12-01): findings F3, F5, F7, F8, F9, F12, F13,
// F18. Exit 1 for bad input with a message naming the file or the option as the user typed it,
// exit 2 for usage errors, nothing that hangs, nothing computed lost, no empty folder left behind.
#include <gtest/gtest.h>
#include <octomap/OcTree.h>
#include <sys/stat.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "core/io/dataset.h"
#include "core/io/trajectory_io.h"
#include "mapping/octomap_builder.h"
#include "tests/support/cli_fixture.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

using testing::Contains;
using testing::ReadAll;

class CliReprobe : public testing::CliFixture {
 protected:
  CliReprobe() : CliFixture("cli_reprobe") {}
};

// F7, F8, F9: `component bogus` was exit 1; a missing --dataset and bad numbers gave messages
// with internal names (dataset_dir, window < dds::kFrameHistoryDepth, frames (empty range)).
TEST_F(CliReprobe, ComponentUsageErrorsExitTwoNamingTheOption) {
  ExpectError(Run({"component", "bogus", "--config", Config()}), 2,
              {"unknown component 'bogus'", "player | detector"});
  ExpectError(Run({"component", "bogus"}), 2, {"unknown component 'bogus'"});
  const auto no_dataset = Run({"component", "player", "--config", Config(), "--domain", "155"});
  ExpectError(no_dataset, 2, {"needs --dataset DIR", "rgb.txt"});
  EXPECT_FALSE(Contains(no_dataset.err, "dataset_dir")) << no_dataset.err;
  ExpectError(Run({"component", "slam"}), 2, {"--config FILE is required"});
  const auto window = Run({"component", "player", "--dataset", dir_, "--config", Config(),
                           "--window", "9", "--domain", "155"});
  ExpectError(window, 2, {"--window", "'9'"});
  EXPECT_FALSE(Contains(window.err, "kFrameHistoryDepth")) << window.err;
  const auto frames = Run({"component", "player", "--dataset", dir_, "--config", Config(),
                           "--frames", "5:3", "--domain", "155"});
  ExpectError(frames, 2, {"--frames '5:3'", "empty range"});
  ExpectError(Run({"component", "player", "--dataset", dir_, "--config", Config(), "--frames",
                   "x:3", "--domain", "155"}),
              2, {"--frames"});
  ExpectError(
      Run({"component", "recorder", "--config", Config(), "--partition", "*", "--domain", "155"}),
      2, {"--partition '*'", "wildcards"});
  ExpectError(
      Run({"run", dir_, "--config", Config(), "--partition", "run*", "--out", dir_ + "/out"}), 2,
      {"--partition 'run*'"});
}

// F9: eval / bench option values were exit 1, --delta named the internal field
// ("invalid option delta: requires std::isfinite(delta) && delta > 0").
// Round 3: `component detector --detector-model bogus` with a settings file ran the settings'
// model without a word (rc 0); `component slam --localization` without a map was exit 1 with
// the internal option check.
TEST_F(CliReprobe, ComponentDetectorModelAndLocalizationAreChecked) {
  ExpectError(Run({"component", "detector", "--config", Config(), "--detector-model", "bogus",
                   "--domain", "155"}),
              1, {"--detector-model", "unknown detector model 'bogus'"});
  ExpectError(Run({"component", "slam", "--config", Config(), "--localization", "--domain", "155"}),
              2, {"--localization needs --load-map"});
}

// Round 3: `eval --plot FOLDER` printed a Python traceback, left a temporary file and exited 0.
TEST_F(CliReprobe, EvalPlotIntoAFolderIsAUsageError) {
  ExpectError(Run({"eval", "gt.txt", "est.txt", "--plot", dir_}), 2, {"--plot", "is a folder"});
}

TEST_F(CliReprobe, OptionValueErrorsOfEvalAndBenchAreUsageErrors) {
  const std::string gt = dir_ + "/gt.txt";
  std::ofstream(gt) << "1.0 0 0 0 0 0 0 1\n2.0 1 0 0 0 0 0 1\n3.0 2 0 0 0 0 0 1\n";
  for (const auto& [option, value] :
       std::vector<std::pair<std::string, std::string>>{{"--delta", "-1"},
                                                        {"--delta", "0"},
                                                        {"--max-diff", "abc"},
                                                        {"--max-diff", "0"},
                                                        {"--offset", "nan"}}) {
    const auto r = Run({"eval", gt, gt, option, value});
    ExpectError(r, 2, {option + ": expected", "'" + value + "'"});
    EXPECT_FALSE(Contains(r.err, "invalid option")) << r.err;
  }
  EXPECT_EQ(Run({"eval", gt, gt}).code, 0);
  ExpectError(Run({"bench", dir_, "--runs", "0"}), 2, {"--runs: expected an integer in 1..100"});
}

// F5 / F18: values were echoed whole (a 100 kB argument) and binary bytes raw.
TEST_F(CliReprobe, EchoedArgumentsAreBoundedAndEscaped) {
  const std::string huge(100000, 'z');
  const auto r1 = Run({"run", dir_, "--config", Config(), "--filter", huge, "--out", dir_ + "/o"});
  EXPECT_TRUE(r1.code == 1 || r1.code == 2) << r1.err.substr(0, 500);
  EXPECT_LT(r1.err.size(), 3000u) << r1.err.substr(0, 500);
  EXPECT_TRUE(Contains(r1.err, "(100000 bytes)")) << r1.err.substr(0, 500);
  // A missing file named by a 100 kB path with escape sequences: the message is cut and escaped
  // (at most 2000 characters for any message).
  const auto r2 = Run({"eval", std::string("\x1b[31m\x01") + huge, dir_ + "/est.txt"});
  EXPECT_EQ(r2.code, 1) << r2.err.substr(0, 500);
  EXPECT_LT(r2.err.size(), 2300u) << r2.err.substr(0, 500);
  EXPECT_TRUE(Contains(r2.err, "\\x1b[31m\\x01zzz")) << r2.err.substr(0, 500);
  EXPECT_FALSE(Contains(r2.err, "\x1b")) << r2.err.substr(0, 500);
  const auto r3 = Run({std::string("\x1b]0;x\x07") + "cmd"});
  EXPECT_EQ(r3.code, 2);
  EXPECT_TRUE(Contains(r3.err, "unknown command '\\x1b]0;x\\x07cmd'")) << r3.err;
}

// F3: --load-octomap given a FIFO blocked forever; binary inputs must be regular files.
TEST_F(CliReprobe, BinaryInputThatIsAFifoIsRefusedAtOnce) {
  const std::string fifo = dir_ + "/map.ot";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  const auto r = RunWithin({"run", dir_, "--config", Config(), "--out", dir_ + "/out", "--direct",
                            "--load-octomap", fifo},
                           20);
  ExpectError(r, 1, {"--load-octomap", fifo, "not a regular file"});
  // The same for a folder.
  ExpectError(RunWithin({"run", dir_, "--config", Config(), "--out", dir_ + "/out", "--direct",
                         "--load-octomap", dir_},
                        20),
              1, {"--load-octomap", "not a regular file"});
}

// F18: an early error left an empty --out folder (and its new parents) behind.
TEST_F(CliReprobe, EarlyErrorLeavesNoEmptyOutputFolder) {
  const std::string bad = dir_ + "/bad.yaml";
  std::ofstream(bad) << ReadAll(Config()) << "ThDepth: far\n";
  const std::string out = dir_ + "/new/nested/out";
  for (const char* command : {"run", "map"}) {
    const auto r = Run({command, dir_, "--config", bad, "--out", out, "--quiet"});
    ExpectError(r, 1, {"ThDepth"});
    EXPECT_FALSE(fs::exists(dir_ + "/new")) << command;
  }
  // A folder that existed before stays, with what it held.
  fs::create_directories(dir_ + "/kept");
  std::ofstream(dir_ + "/kept/note.txt") << "mine\n";
  ExpectError(Run({"run", dir_, "--config", bad, "--out", dir_ + "/kept"}), 1, {"ThDepth"});
  fs::create_directories(dir_ + "/empty_before");
  ExpectError(Run({"run", dir_, "--config", bad, "--out", dir_ + "/empty_before"}), 1, {"ThDepth"});
  EXPECT_EQ(ReadAll(dir_ + "/kept/note.txt"), "mine\n");
  EXPECT_TRUE(fs::is_directory(dir_ + "/empty_before"));
}

// F12: a malformed groundtruth.txt was found only after the run (exit 1 then). It is found before
// the first frame: a warning naming file:line, and the run goes on without evaluation.
TEST_F(CliReprobe, MalformedGroundTruthWarnsUpFrontAndTheRunGoesOn) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string dataset = SmallDataset(source, 20, "gt");
  std::ofstream(dataset + "/groundtruth.txt")
      << "# ground truth\n1548339822.0 0 0 0 0 0 0 1\n1548339822.1 0 zero 0 0 0 0 1\n";
  for (const char* mode : {"--direct", "--processes"}) {
    const std::string out = dir_ + "/gt_out_" + std::string(mode + 2);
    const auto r = Run({"run", dataset, "--config", Config(), "--out", out, "--filter", "none",
                        "--domain", "156", mode});
    EXPECT_EQ(r.code, 0) << mode << "\n" << r.err;
    const std::string warning = "warning: " + dataset + "/groundtruth.txt:3:";
    EXPECT_TRUE(Contains(r.err, warning)) << mode << "\n" << r.err;
    EXPECT_TRUE(Contains(r.err, "goes on without evaluation")) << r.err;
    EXPECT_TRUE(Contains(r.out, "ATE: not evaluated")) << r.out;
    EXPECT_GE(ReadTumTrajectory(out + "/trajectory.txt").size(), 18u) << mode;
    if (std::string(mode) == "--direct") {
      // Before the first frame: the warning precedes the progress line.
      EXPECT_LT(r.err.find(warning), r.err.find("[run] frame")) << r.err;
    }
  }
}

// F13: a direct run that failed mid-way (an image that does not decode) wrote nothing. The frames
// before the error are written (atomically) and the run says so, exit 1.
TEST_F(CliReprobe, DirectRunThatFailsLateWritesWhatWasComputed) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string dataset = SmallDataset(source, 30, "late");
  // Entry 20's colour image: a truncated copy.
  const RgbdDataset d = RgbdDataset::Open(dataset);
  const std::string bytes = ReadAll(d.frame(20).rgb_path);
  const std::string broken = dataset + "/broken.png";
  std::ofstream(broken, std::ios::binary) << bytes.substr(0, bytes.size() / 3);
  std::string rgb = ReadAll(dataset + "/rgb.txt");
  const std::string old_path = d.frame(20).rgb_path;
  rgb.replace(rgb.find(old_path), old_path.size(), "broken.png");
  std::ofstream(dataset + "/rgb.txt") << rgb;
  const std::string out = dir_ + "/late_out";
  const auto r = Run({"run", dataset, "--config", Config(), "--out", out, "--filter", "none",
                      "--direct", "--quiet"});
  ExpectError(r, 1,
              {"broken.png", "rgb.txt:21", "stopped by an error after 20 frames",
               "outputs of those frames are written"});
  const auto trajectory = ReadTumTrajectory(out + "/trajectory.txt");
  EXPECT_GE(trajectory.size(), 18u);
  EXPECT_LE(trajectory.size(), 20u);
  const std::string csv = ReadAll(out + "/frames.csv");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 21);  // header + the 20 frames
  EXPECT_TRUE(fs::exists(out + "/map.bt"));
  for (const auto& e : fs::directory_iterator(out))
    EXPECT_FALSE(Contains(e.path().filename().string(), ".tmp.")) << e.path();
}

// Re-probe: a --load-map --localization run adds no keyframe, so the mapper had nothing to insert
// and no map.bt was written; it is now the loaded map's static map (its map points).
TEST_F(CliReprobe, LocalizationRunWritesTheLoadedMapsStaticMap) {
  DYGSLAM_REQUIRE_DATASET(data, "bonn_crowd_part");
  const std::string map_file = dir_ + "/slam.map";
  const auto saved =
      Run({"run", data, "--config", Config(), "--frames", "0:20", "--direct", "--filter", "none",
           "--quiet", "--no-map", "--out", dir_ + "/first", "--save-map", map_file});
  ASSERT_EQ(saved.code, 0) << saved.err;
  const auto r =
      Run({"run", data, "--config", Config(), "--frames", "0:20", "--direct", "--filter", "none",
           "--quiet", "--out", dir_ + "/second", "--load-map", map_file, "--localization"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(Contains(r.out, "map.bt: the static map of " + map_file)) << r.out;
  ASSERT_TRUE(fs::exists(dir_ + "/second/map.bt")) << r.out;
  // A real OctoMap: occupied voxels where the map points are, free space before them.
  const auto tree = ReadOctoMap(dir_ + "/second/map.bt");
  size_t occupied = 0, free = 0;
  for (auto it = tree->begin_leafs(); it != tree->end_leafs(); ++it)
    (tree->isNodeOccupied(*it) ? occupied : free) += 1;
  EXPECT_GT(occupied, 100u);
  EXPECT_GT(free, occupied);
  EXPECT_FALSE(fs::exists(dir_ + "/second/map.ot"));  // no --save-map
  // Round 3: with --save-map the run writes map.ot beside map.bt, as the README says (it did not).
  const auto saving = Run({"run", data, "--config", Config(), "--frames", "0:20", "--direct",
                           "--filter", "none", "--quiet", "--out", dir_ + "/third", "--load-map",
                           map_file, "--localization", "--save-map", dir_ + "/again.map"});
  ASSERT_EQ(saving.code, 0) << saving.err;
  EXPECT_TRUE(fs::exists(dir_ + "/third/map.bt"));
  EXPECT_GT(ReadOctoMap(dir_ + "/third/map.ot")->size(), 0u);
}

}  // namespace
}  // namespace dygslam
