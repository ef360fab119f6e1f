// Usage errors of the command line (exit 2) name the option as the user typed it, never an
// internal field; echoed values are bounded and escaped; an early error leaves no empty --out
// folder behind. `component` commands run on DDS domain 155 inside the netns emulator.
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

class CliUsage : public testing::CliFixture {
 protected:
  CliUsage() : CliFixture("cli_usage") {}
};

// `component bogus` was exit 1; a missing --dataset and bad numbers gave messages
// with internal names (dataset_dir, window < dds::kFrameHistoryDepth, frames (empty range)).
TEST_F(CliUsage, ComponentUsageErrorsExitTwoNamingTheOption) {
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

// Eval / bench option values were exit 1, --delta named the internal field
// ("invalid option delta: requires std::isfinite(delta) && delta > 0").
// `component detector --detector-model bogus` with a settings file ran the settings'
// model without a word (rc 0); `component slam --localization` without a map was exit 1 with
// the internal option check.
TEST_F(CliUsage, ComponentDetectorModelAndLocalizationAreChecked) {
  ExpectError(Run({"component", "detector", "--config", Config(), "--detector-model", "bogus",
                   "--domain", "155"}),
              1, {"--detector-model", "unknown detector model 'bogus'"});
  ExpectError(Run({"component", "slam", "--config", Config(), "--localization", "--domain", "155"}),
              2, {"--localization needs --load-map"});
}

// `eval --plot FOLDER` printed a Python traceback, left a temporary file and exited 0.
TEST_F(CliUsage, EvalPlotIntoAFolderIsAUsageError) {
  ExpectError(Run({"eval", "gt.txt", "est.txt", "--plot", dir_}), 2, {"--plot", "is a folder"});
}

TEST_F(CliUsage, OptionValueErrorsOfEvalAndBenchAreUsageErrors) {
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
  fs::copy_file(gt, dir_ + "/est.txt");
  EXPECT_EQ(Run({"eval", gt, dir_ + "/est.txt"}).code, 0);
  ExpectError(Run({"bench", dir_, "--runs", "0"}), 2, {"--runs: expected an integer in 1..100"});
}

// Values were echoed whole (a 100 kB argument) and binary bytes raw.
TEST_F(CliUsage, EchoedArgumentsAreBoundedAndEscaped) {
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

// An early error left an empty --out folder (and its new parents) behind.
TEST_F(CliUsage, EarlyErrorLeavesNoEmptyOutputFolder) {
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

}  // namespace
}  // namespace dygslam
