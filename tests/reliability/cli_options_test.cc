// Command-line options checked before any work: `bench` options (--out a file, --configs with an
// unknown name, --features-frame out of range), `synth` values out of range, an option given twice
// with different values: usage errors (exit 2) naming the option as typed.
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
#include "tests/support/cli_fixture.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

using testing::Contains;

class CliOptions : public testing::CliFixture {
 protected:
  CliOptions() : CliFixture("cli_options") {}
  void TearDown() override { fs::remove_all(dir_); }
};

// Bench options checked up front, named as typed.
TEST_F(CliOptions, BenchOptionsAreCheckedBeforeAnyRun) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string ds = SmallDataset(source, 12, "ds", /*with_groundtruth=*/true);
  ExpectError(Run({"bench", ds, "--out", Config(), "--runs", "1"}), 1,
              {"--out", "exists and is not a folder"});
  ExpectError(Run({"bench", ds, "--configs", "none,bogus", "--out", dir_ + "/b", "--runs", "1"}), 2,
              {"--configs", "bogus"});
  const auto f = Run({"bench", ds, "--features-frame", "-5", "--out", dir_ + "/b", "--runs", "1",
                      "--configs", "none", "--no-baseline"});
  ExpectError(f, 2, {"--features-frame"});
  EXPECT_FALSE(fs::exists(dir_ + "/b/runs.csv")) << "ran before checking --features-frame";
}

// Synth's range errors are usage errors naming the option, without C++ text.
TEST_F(CliOptions, SynthRangeErrorsNameTheOption) {
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

// An option given twice with different values is a usage error naming it.
TEST_F(CliOptions, OptionGivenTwiceWithDifferentValuesIsAUsageError) {
  const auto r = Run(
      {"run", dir_, "--config", Config(), "--out", dir_ + "/a", "--out", dir_ + "/b", "--direct"});
  ExpectError(r, 2, {"option --out given twice with different values"});
  EXPECT_FALSE(fs::exists(dir_ + "/a"));
  EXPECT_FALSE(fs::exists(dir_ + "/b"));
  const auto e = Run({"eval", "x", "y", "--delta=1", "--delta", "2"});
  ExpectError(e, 2, {"--delta given twice"});
}

}  // namespace
}  // namespace dygslam
