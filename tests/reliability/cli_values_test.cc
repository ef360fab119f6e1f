// The command line's own contract: an option whose value is missing never takes the next option as
// its value (`--out --no-map` wrote into ./--no-map/), and what a command prints to stdout must
// reach it (`eval --json > /dev/full`, `version`, `help` exited 0 with nothing written).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "core/io/trajectory_io.h"
#include "tests/support/cli_fixture.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;
using testing::Contains;
using testing::ReadAll;

class Cli : public testing::CliFixture {
 protected:
  Cli() : CliFixture("cli") {}

  // `dygslam ARGS` run in folder `cwd` with stdout to `stdout_path` (e.g. /dev/full) or, when
  // `closed_pipe`, into a pipe whose reader has gone; stderr captured.
  testing::ProcessResult RunIn(const std::string& cwd, const std::vector<std::string>& args,
                               const std::string& stdout_path, bool closed_pipe = false) {
    const std::string err = dir_ + "/cli.err";
    std::vector<std::string> copy = {testing::DygslamBinary()};
    copy.insert(copy.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (auto& a : copy) argv.push_back(a.data());
    argv.push_back(nullptr);
    int fds[2] = {-1, -1};
    if (closed_pipe && pipe(fds) != 0) return {};
    if (closed_pipe) close(fds[0]);  // the reader is gone before anything is written
    const pid_t pid = fork();
    if (pid == 0) {
      if (chdir(cwd.c_str()) != 0) std::_Exit(125);
      const int out = closed_pipe ? fds[1] : open(stdout_path.c_str(), O_WRONLY | O_CREAT, 0644);
      if (out < 0 || dup2(out, STDOUT_FILENO) < 0) std::_Exit(126);
      if (!std::freopen(err.c_str(), "w", stderr)) std::_Exit(126);
      execv(argv[0], argv.data());
      std::_Exit(127);
    }
    if (closed_pipe) close(fds[1]);
    std::string diagnostics;
    testing::ProcessResult r;
    r.code = testing::WaitForExit(pid, 60, &diagnostics);
    r.err = ReadAll(err) + diagnostics;
    return r;
  }

  std::string Trajectory(const std::string& name, double x) {
    const std::string path = dir_ + "/" + name;
    std::ofstream f(path);
    for (int i = 0; i < 40; ++i) f << 100 + 0.1 * i << " " << x + 0.01 * i << " 0 0 0 0 0 1\n";
    return path;
  }
};

TEST_F(Cli, AnOptionIsNeverTakenAsTheValueOfTheOptionBeforeIt) {
  const std::string cwd = dir_ + "/cwd";
  fs::create_directories(cwd);
  const std::string gt = Trajectory("gt.txt", 0), est = Trajectory("est.txt", 0.5);
  struct Case {
    std::vector<std::string> args;
    std::string message;
  };
  const std::vector<Case> cases = {
      {{"run", dir_, "--out", "--no-map"},
       "option --out needs a value (DIR), got the option '--no-map'"},
      {{"map", dir_, "--config", "--quiet"},
       "option --config needs a value (FILE), got the option '--quiet'"},
      {{"eval", gt, est, "--save-aligned", "--json"},
       "option --save-aligned needs a value (FILE), got the option '--json'"},
      {{"synth", dir_ + "/s", "--frames", "--noise"},
       "option --frames needs a value (N), got the option '--noise'"},
  };
  for (const Case& c : cases) {
    const auto r = RunIn(cwd, c.args, dir_ + "/cli.out");
    ExpectError(r, 2, {c.message, "--" + c.args[c.args.size() - 2].substr(2) + "=VALUE"});
  }
  // Nothing was written where the command ran: no ./--no-map/, ./--json.
  EXPECT_TRUE(fs::is_empty(cwd));
  // A value that starts with "--" is given with '=': taken as it is.
  const auto r = RunIn(cwd, {"eval", gt, est, "--save-aligned=--aligned.txt"}, dir_ + "/cli.out");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::exists(fs::path(cwd) / "--aligned.txt"));
}

// An empty or blank value (`--config=`, `--out " "`) is a usage error naming the option, in
// every command (an invisible path would only show up later as a name of spaces).
TEST_F(Cli, AnEmptyOrBlankValueIsAUsageErrorNamingTheOption) {
  const std::string cwd = dir_ + "/cwd_blank";
  fs::create_directories(cwd);
  const std::vector<std::vector<std::string>> cases = {
      {"run", dir_, "--config="},         {"run", dir_, "--config", " "},
      {"map", dir_, "--config="},         {"bench", dir_, "--config="},
      {"run", dir_, "--out", "  "},       {"eval", dir_, dir_, "--save-aligned="},
      {"synth", dir_ + "/s", "--frames="}};
  for (const auto& args : cases) {
    const auto r = RunIn(cwd, args, dir_ + "/cli.out");
    const std::string& last = args.back();
    const std::string option =
        last.rfind("--", 0) == 0 ? last.substr(0, last.find('=')) : args[args.size() - 2];
    ExpectError(r, 2, {"option " + option + " needs a value", "got"});
  }
  EXPECT_TRUE(fs::is_empty(cwd));
  // `dygslam component` takes empty values as "not given": compose files pass optional settings
  // as empty variables.
  const auto component =
      RunIn(cwd, {"component", "mapper", "--load-octomap", "", "--help"}, dir_ + "/cli.out");
  EXPECT_EQ(component.code, 0) << component.err;
}

// --rate: 0 (as fast as taken) or 0.01 to 1000; a rate that would wait minutes per frame is a
// usage error, not a run.
TEST_F(Cli, RunRateBelowTheSlowestReplayIsAUsageError) {
  const std::string cwd = dir_ + "/cwd_rate";
  fs::create_directories(cwd);
  for (const std::string value : {"0.0001", "0.009", "-1", "1001"}) {
    const auto r = RunIn(cwd, {"run", dir_, "--rate", value, "--direct"}, dir_ + "/cli.out");
    ExpectError(r, 2, {"--rate", value});
  }
  EXPECT_TRUE(fs::is_empty(cwd));
}

// A depth unit of 0 (every depth would be 0 m) is a usage error naming the option as typed,
// before any DDS participant is made; so is one outside the range.
TEST_F(Cli, BridgeDepthUnitZeroIsAUsageErrorNamingTheOption) {
  const std::string cwd = dir_ + "/cwd_bridge";
  fs::create_directories(cwd);
  for (const std::string value : {"0", "0.0", "-0"}) {
    const auto r = RunIn(cwd, {"bridge", "--depth-unit", value}, dir_ + "/cli.out");
    ExpectError(r, 2, {"--depth-unit " + value + ": must be > 0"});
    EXPECT_FALSE(Contains(r.err, "depth_unit")) << r.err;  // the option's name, not the field's
  }
  ExpectError(RunIn(cwd, {"bridge", "--depth-unit", "-1"}, dir_ + "/cli.out"), 2,
              {"--depth-unit", "-1"});
}

TEST_F(Cli, AFailedWriteToStandardOutputFailsTheCommand) {
  const std::string gt = Trajectory("gt.txt", 0), est = Trajectory("est.txt", 0.5);
  const std::vector<std::vector<std::string>> commands = {
      {"version"}, {"help"}, {"eval", gt, est, "--json"}, {"eval", gt, est}, {"eval", "--help"}};
  for (const auto& args : commands) {
    const auto r = RunIn(dir_, args, "/dev/full");
    ExpectError(r, 1, {"error: cannot write to standard output: No space left on device"});
    // The same command with a working stdout succeeds (the failure is the write, nothing else).
    EXPECT_EQ(RunIn(dir_, args, dir_ + "/ok.out").code, 0) << args[0];
  }
}

// A reader that closed its pipe on purpose (`dygslam version | head -c 0`) is not a failure.
TEST_F(Cli, AReaderThatClosedItsPipeIsNotAFailure) {
  const auto r = RunIn(dir_, {"help"}, "", /*closed_pipe=*/true);
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_FALSE(Contains(r.err, "cannot write")) << r.err;
}

// A run whose summary cannot reach stdout (`> /dev/full`) exits 1, and its eval.json says so:
// exit code 1 and the reason (before: the command exited 1, eval.json said 0 and no error).
TEST_F(Cli, ARunWhoseSummaryCannotBeWrittenSaysSoInItsEvalJson) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string data = SmallDataset(source, 20, "data");
  const auto r = RunIn(dir_,
                       {"run", data, "--config", Config(), "--filter", "none", "--direct",
                        "--no-map", "--quiet", "--out", dir_ + "/full"},
                       "/dev/full");
  ExpectError(r, 1, {"error: cannot write to standard output: No space left on device"});
  const std::string json = ReadAll(dir_ + "/full/eval.json");
  EXPECT_TRUE(Contains(json, "\"exit_code\": 1")) << json;
  EXPECT_TRUE(Contains(json, "cannot write to standard output: No space left on device")) << json;
  EXPECT_EQ(ReadTumTrajectory(dir_ + "/full/trajectory.txt").size(), 20u);
}

// A range beyond the dataset says which range and the dataset's size (before: "empty range").
TEST_F(Cli, AnEmptyFrameRangeSaysWhyWithTheDatasetSize) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string data = SmallDataset(source, 10, "data");
  ExpectError(Run({"run", data, "--config", Config(), "--frames", "500:600", "--out", dir_ + "/o"}),
              2,
              {"--frames: empty range '500:600' (rgb.txt entries 500 to 600)",
               "FIRST 500 is beyond the dataset's 10 rgb.txt entries (0..9)"});
  ExpectError(Run({"map", data, "--config", Config(), "--frames", "5:3", "--out", dir_ + "/o"}), 2,
              {"empty range '5:3'", "FIRST must be below LAST (the dataset has 10 rgb.txt"});
}

// A message about a very long path keeps its reason (the end of the message), cut in the middle.
TEST_F(Cli, AMessageAboutAVeryLongPathKeepsItsReason) {
  const std::string gt = Trajectory("gt.txt", 0);
  const std::string missing = dir_ + "/" + std::string(3000, 'x') + ".txt";
  const auto r = Run({"eval", missing, gt});
  ExpectError(r, 1, {"dygslam eval: error: " + dir_, "-byte message, cut) ... ", "file not found"});
  EXPECT_LT(r.err.size(), 2200u) << r.err.size();
}

}  // namespace
}  // namespace dygslam
