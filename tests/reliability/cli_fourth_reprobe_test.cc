// Fourth re-probe of issue 20 (2026-12-02), the command-line half: each case failed before its
// fix (tests/reliability/probe/fresh_probe.sh finds them again).
//   P5  an output file that exists as a device or a FIFO (`vocab /dev/full`, `eval --save-aligned
//       FIFO`) was replaced by a regular file (the atomic write renamed over it): exit 0, and
//       the device node was gone
//   P6  `bench --out FILE` gave "internal error: filesystem error" after nothing was checked;
//       `bench --configs none,bogus` was exit 1 without naming --configs; `bench
//       --features-frame -5` was found only after every run
//   P7  `synth` values out of range (--objects 9, --room 1,1,1, --speed -1, ...) were exit 1 with
//       the options struct's field and C++ check ("5 m).allFinite() and ...") instead of a usage
//       error naming the option
//   P8  settings: a second YAML document and a merge key were ignored without a word (run)
//   P9  --detections boxes outside the image masked nothing without a word
//   P12 `run --direct` / `map` whose --out was removed mid-run failed at the end ("cannot write:
//       directory does not exist") and lost every output of the frames processed
//   P13 an option given twice with different values (`run --out a --out b`) took the last one
//       without a word
//   P10 `bench` had no stop handling: SIGTERM (or Ctrl-C) after hours of runs ended it with exit
//       143 / 130 and no runs.csv or report of the runs done (the probe's SIGINT to a background
//       bench was even ignored: it inherits SIG_IGN and installed no handler)
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/types.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "core/io/dataset.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

std::string Config() { return std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/bonn.yaml"; }

bool Contains(const std::string& text, const std::string& needle) {
  return text.find(needle) != std::string::npos;
}

class CliFourthReprobe : public ::testing::Test {
 protected:
  void SetUp() override {
    DYGSLAM_REQUIRE_FILE(testing::DygslamBinary(), "dygslam binary");
    dir_ = testing::MakeTempDir("cli_fourth_reprobe");
  }
  void TearDown() override { fs::remove_all(dir_); }
  testing::ProcessResult Run(const std::vector<std::string>& args) {
    return testing::RunDygslam(args, dir_);
  }
  static void ExpectError(const testing::ProcessResult& r, int code,
                          const std::vector<std::string>& needles) {
    EXPECT_EQ(r.code, code) << r.err;
    EXPECT_FALSE(Contains(r.err, "internal error")) << r.err;
    for (const std::string& n : needles)
      EXPECT_TRUE(Contains(r.err, n)) << "'" << n << "' not in\n" << r.err.substr(0, 3000);
  }
  // The first `n` frames of bonn_crowd_part (images by absolute path) in dir_/name.
  std::string SmallDataset(const std::string& source, size_t n, const std::string& name) {
    const fs::path dir = fs::path(dir_) / name;
    fs::create_directories(dir);
    const RgbdDataset d = RgbdDataset::Open(source);
    std::ofstream rgb(dir / "rgb.txt"), depth(dir / "depth.txt");
    for (size_t i = 0; i < n; ++i) {
      rgb << d.frame(i).rgb_stamp.ToString() << " " << d.frame(i).rgb_path << "\n";
      depth << d.frame(i).depth_stamp.ToString() << " " << d.frame(i).depth_path << "\n";
    }
    fs::copy_file(d.groundtruth_path(), dir / "groundtruth.txt");
    return dir.string();
  }
  std::string dir_;
};

// P5: a FIFO (or a device) named as an output file is refused and left as it was.
TEST_F(CliFourthReprobe, OutputFileThatIsAFifoIsLeftAlone) {
  const std::string fifo = dir_ + "/out.fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  // eval --save-aligned: ground truth against itself (a valid evaluation).
  std::ofstream(dir_ + "/gt.txt") << "1 0 0 0 0 0 0 1\n2 1 0 0 0 0 0 1\n3 1 1 0 0 0 0 1\n"
                                  << "4 0 1 1 0 0 0 1\n";
  const auto r = Run({"eval", dir_ + "/gt.txt", dir_ + "/gt.txt", "--save-aligned", fifo});
  ExpectError(r, 1, {fifo, "a FIFO, not a regular file"});
  EXPECT_TRUE(fs::is_fifo(fifo)) << "the FIFO was replaced";
  // vocab OUT_FILE: the smallest vocabulary, refused before or after training, never renamed over.
  const auto v = Run({"vocab", fifo, "--scenes", "1", "--frames-per-scene", "1", "--depth", "1",
                      "--branching", "2", "--quiet"});
  ExpectError(v, 1, {"a FIFO, not a regular file"});
  EXPECT_TRUE(fs::is_fifo(fifo)) << "the FIFO was replaced";
  for (const auto& entry : fs::directory_iterator(dir_))
    EXPECT_FALSE(Contains(entry.path().filename().string(), ".tmp.")) << entry.path();
}

// P6: bench options checked up front, named as typed.
TEST_F(CliFourthReprobe, BenchOptionsAreCheckedBeforeAnyRun) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string ds = SmallDataset(source, 12, "ds");
  ExpectError(Run({"bench", ds, "--out", Config(), "--runs", "1"}), 1,
              {"--out", "exists and is not a folder"});
  ExpectError(Run({"bench", ds, "--configs", "none,bogus", "--out", dir_ + "/b", "--runs", "1"}), 2,
              {"--configs", "bogus"});
  const auto f = Run({"bench", ds, "--features-frame", "-5", "--out", dir_ + "/b", "--runs", "1",
                      "--configs", "none", "--no-baseline"});
  ExpectError(f, 2, {"--features-frame"});
  EXPECT_FALSE(fs::exists(dir_ + "/b/runs.csv")) << "ran before checking --features-frame";
}

// P7: synth's range errors are usage errors naming the option, without C++ text.
TEST_F(CliFourthReprobe, SynthRangeErrorsNameTheOption) {
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {{"--objects", "9"}, "--objects"},
      {{"--fps", "0"}, "--fps"},
      {{"--room", "1,1,1"}, "--room"},
      {{"--room", "nan,5,3"}, "--room"},
      {{"--loop-path", "1e9,1e9"}, "--loop-path"},
      {{"--speed", "-1", "--loop-path", "2,1.5"}, "--speed"},
      {{"--supersampling", "9"}, "--supersampling"},
      {{"--max-depth", "-1"}, "--max-depth"},
  };
  for (const auto& [options, named] : cases) {
    std::vector<std::string> args = {"synth", dir_ + "/s", "--frames", "1", "--quiet"};
    args.insert(args.end(), options.begin(), options.end());
    const auto r = Run(args);
    // "--objects: out of range ..." or, for plain numbers, the shared parser's "--objects:
    // expected an integer in 0..4, got '9'": either way a usage error naming the option.
    ExpectError(r, 2, {"dygslam synth: " + named + ": "});
    EXPECT_FALSE(Contains(r.err, "requires")) << r.err;
    EXPECT_FALSE(Contains(r.err, ").")) << "C++ expression in the message: " << r.err;
    EXPECT_FALSE(fs::exists(dir_ + "/s/rgb.txt")) << options[0];
  }
}

// P8: a second document or a merge key in a settings file is an error of `run` with the line.
TEST_F(CliFourthReprobe, SettingsDocumentsAndMergeKeysAreErrors) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string ds = SmallDataset(source, 4, "ds");
  const std::string bonn = testing::ReadAll(Config());
  const int lines = static_cast<int>(std::count(bonn.begin(), bonn.end(), '\n'));
  std::ofstream(dir_ + "/two.yaml") << bonn << "---\nCamera.fx: 500\n";
  ExpectError(Run({"run", ds, "--config", dir_ + "/two.yaml", "--out", dir_ + "/o", "--direct"}), 1,
              {"two.yaml:" + std::to_string(lines + 2) + ":", "second YAML document"});
  std::ofstream(dir_ + "/merge.yaml")
      << bonn << "base: &b {alpha: 0.9}\nDynamicFilter:\n  <<: *b\n";
  ExpectError(Run({"run", ds, "--config", dir_ + "/merge.yaml", "--out", dir_ + "/o", "--direct"}),
              1, {"merge.yaml:" + std::to_string(lines + 3) + ":", "merge key"});
  EXPECT_FALSE(fs::exists(dir_ + "/o")) << "a failed run left its --out folder";
}

// P9: boxes outside the image are said, with their count.
TEST_F(CliFourthReprobe, DetectionsOutsideTheImageAreWarned) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string ds = SmallDataset(source, 4, "ds");
  const RgbdDataset d = RgbdDataset::Open(ds);
  std::ofstream det(dir_ + "/det.txt");
  for (size_t i = 0; i < d.size(); ++i) {
    const std::string stamp = d.frame(i).rgb_stamp.ToString();
    det << stamp << " 100 100 50 80 0 0.9\n";      // inside
    det << stamp << " 1e6 1e6 50 80 0 0.9\n";      // far outside
    det << stamp << " -200 -300 100 100 0 0.9\n";  // outside, above the top-left corner
  }
  det.close();
  const auto r = Run({"run", ds, "--config", Config(), "--out", dir_ + "/o", "--direct", "--filter",
                      "boxes", "--detections", dir_ + "/det.txt", "--quiet"});
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(Contains(r.err, "8 of its 12 boxes lie outside the 640x480 image")) << r.err;
}

// P12: --out removed while the run goes: made again, said, every output written.
TEST_F(CliFourthReprobe, OutFolderRemovedMidRunIsMadeAgain) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string ds = SmallDataset(source, 60, "ds");
  for (const std::string command : {"run", "map"}) {
    const std::string out = dir_ + "/o_" + command;
    std::vector<std::string> args = {command, ds,        "--config", Config(), "--out",
                                     out,     "--quiet", "--filter", "none"};
    if (command == "run") args.push_back("--direct");
    const pid_t pid = testing::SpawnDygslam(args, out + ".out", out + ".err");
    ASSERT_GT(pid, 0);
    // The folder is made before the first frame (checked for writing); remove it then.
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (!fs::exists(out) && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    ASSERT_TRUE(fs::exists(out)) << command;
    fs::remove_all(out);
    std::string diagnostics;
    const int code = testing::WaitForExit(pid, 300, &diagnostics);
    const std::string err = testing::ReadAll(out + ".err");
    EXPECT_EQ(code, 0) << command << ": " << err << diagnostics;
    EXPECT_TRUE(Contains(err, "--out '" + out + "' was removed while the command ran")) << err;
    const std::string trajectory = testing::ReadAll(out + "/trajectory.txt");
    EXPECT_GE(std::count(trajectory.begin(), trajectory.end(), '\n'), 50) << command;
  }
}

// P13: an option given twice with different values is a usage error naming it.
TEST_F(CliFourthReprobe, OptionGivenTwiceWithDifferentValuesIsAUsageError) {
  const auto r = Run(
      {"run", dir_, "--config", Config(), "--out", dir_ + "/a", "--out", dir_ + "/b", "--direct"});
  ExpectError(r, 2, {"option --out given twice with different values"});
  EXPECT_FALSE(fs::exists(dir_ + "/a"));
  EXPECT_FALSE(fs::exists(dir_ + "/b"));
  const auto e = Run({"eval", "x", "y", "--delta=1", "--delta", "2"});
  ExpectError(e, 2, {"--delta given twice"});
}

// P10: a stop signal between runs writes the report of the runs done, exit 0.
TEST_F(CliFourthReprobe, BenchStoppedBySignalWritesTheRunsDone) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string ds = SmallDataset(source, 8, "ds");
  const std::string out = dir_ + "/b";
  const pid_t pid =
      testing::SpawnDygslam({"bench", ds, "--runs", "3", "--configs", "none", "--no-baseline",
                             "--no-pictures", "--out", out, "--deterministic"},
                            dir_ + "/bench.out", dir_ + "/bench.err");
  ASSERT_GT(pid, 0);
  // Run 1 is scored once its line ("... ATE RMSE ...") is printed: stop the bench after it.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (!Contains(testing::ReadAll(dir_ + "/bench.err"), "ATE RMSE") &&
         std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  ASSERT_TRUE(Contains(testing::ReadAll(dir_ + "/bench.err"), "ATE RMSE"))
      << testing::ReadAll(dir_ + "/bench.err");
  ::kill(pid, SIGTERM);
  std::string diagnostics;
  const int code = testing::WaitForExit(pid, 120, &diagnostics);
  const std::string err = testing::ReadAll(dir_ + "/bench.err");
  EXPECT_EQ(code, 0) << err << diagnostics;
  EXPECT_TRUE(Contains(err, "stopped by signal 15 after 1 of 3 runs")) << err;
  const std::string csv = testing::ReadAll(out + "/runs.csv");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 2) << "header + run 1:\n" << csv;
  EXPECT_TRUE(Contains(testing::ReadAll(out + "/report.md"), "stopped by signal 15"));
}

}  // namespace
}  // namespace dygslam
