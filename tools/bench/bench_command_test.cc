// `dygslam bench --quick` end to end on a generated sequence: the report is complete, the
// pictures exist, BENCHMARKS.md changes only between the markers, and every number agrees with
// `dygslam eval` on the same trajectories.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "core/io/file_util.h"
#include "tests/support/test_support.h"
#include "tools/bench/bench_report.h"
#include "tools/synth/synthetic_sequence.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

struct CommandOutput {
  int exit_code = -1;
  std::string stdout_text;
};

CommandOutput RunDygslam(const std::string& args, const std::string& stderr_file = "/dev/null") {
  const std::string cmd = std::string(DYGSLAM_EXECUTABLE) + " " + args + " 2>" + stderr_file;
  CommandOutput out;
  FILE* pipe = popen(cmd.c_str(), "r");
  if (pipe == nullptr) return out;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof(buf), pipe)) > 0) out.stdout_text.append(buf, n);
  const int status = pclose(pipe);
  out.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return out;
}

std::string ReadText(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

double JsonNumber(const std::string& json, const std::string& key) {
  const size_t k = json.find("\"" + key + "\": ");
  if (k == std::string::npos) return std::nan("");
  return std::strtod(json.c_str() + k + key.size() + 4, nullptr);
}

std::string Fixed4(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.4f", v);
  return buf;
}

bool NonEmptyFile(const fs::path& p) {
  std::error_code ec;
  return fs::is_regular_file(p, ec) && fs::file_size(p, ec) > 1000;
}

TEST(BenchCommand, QuickRunOnGeneratedSequenceMatchesEval) {
  const fs::path root = testing::MakeTempDir("bench_command");
  SyntheticOptions synth;
  synth.num_frames = 40;
  synth.num_moving_objects = 2;
  synth.seed = 3;
  synth.supersampling = 1;
  WriteSyntheticSequence((root / "data" / "gen_seq").string(), synth);
  const std::string head =
      "# Benchmarks\n\n## Dynamic filter on bonn_crowd_part\n\nintro\n<!-- bench:begin -->\n";
  const std::string tail = "<!-- bench:end -->\n\n## Other section\nkept as is\n";
  WriteFileAtomically((root / "BENCHMARKS.md").string(), head + "old figures\n" + tail);

  const fs::path out = root / "out";
  const CommandOutput r =
      RunDygslam("bench " + (root / "data").string() + " --quick --quiet --out " + out.string() +
                     " --update-benchmarks " + (root / "BENCHMARKS.md").string(),
                 (root / "stderr.txt").string());
  ASSERT_EQ(r.exit_code, 0) << r.stdout_text << ReadText((root / "stderr.txt").string());

  // Every configuration and the baseline ran once on all 40 frames.
  const std::vector<BenchRun> runs = ReadBenchRunsCsv((out / "runs.csv").string());
  const std::vector<std::string> configs = {"none", "boxes", "geometry", "full", kBaselineConfig};
  ASSERT_EQ(runs.size(), configs.size());
  const std::string report = ReadText((out / "report.md").string());
  const std::string gt = (root / "data" / "gen_seq" / "groundtruth.txt").string();
  double none_rmse = 0;
  for (size_t i = 0; i < configs.size(); ++i) {
    const BenchRun& run = runs[i];
    SCOPED_TRACE(run.config);
    EXPECT_EQ(run.sequence, "gen_seq");
    EXPECT_EQ(run.config, configs[i]);
    EXPECT_EQ(run.frames, 40);
    // Every configuration tracks the 40 generated frames (measured: 40 of 40); the margin is
    // for the baseline's rejected odometry steps.
    EXPECT_GE(run.poses, 36);
    // The figures are consistent with each other, not only non-zero: frames/s is frames over
    // the loop's wall time, which holds at least the per-frame system time; the stages that run
    // in sequence inside a frame fit in its total.
    EXPECT_NEAR(run.fps * run.loop_seconds, run.frames, 1e-3 * run.frames);
    EXPECT_GE(run.loop_seconds * 1000.0 * 1.001, run.stages.total_ms * run.frames);
    EXPECT_GT(run.stages.total_ms, 0);
    EXPECT_GT(run.peak_rss_mib, 10);
    EXPECT_LT(run.peak_rss_mib, 4096);
    if (run.config != kBaselineConfig) {
      EXPECT_GT(run.stages.orb_ms, 0);
      EXPECT_LE(run.stages.orb_ms + run.stages.tracking_ms, run.stages.total_ms * 1.001);
      // The median frame time is a time (> 0) and cannot exceed twice the mean: at least half
      // the frames take the median or more, and they fit in the sum of all frames.
      EXPECT_GT(run.stages.median_total_ms, 0.0);
      EXPECT_LE(run.stages.median_total_ms, 2.0 * run.stages.total_ms * 1.001);
    }
    if (run.config == "boxes" || run.config == "full") {
      // The generated sequence ships ground-truth boxes (detections.txt): no detector runs, and
      // removing the moving boxes' features beats no filter.
      EXPECT_EQ(run.stages.detection_ms, 0);
      EXPECT_LT(run.ate.rmse, none_rmse);
    }
    if (run.config == "none") {
      EXPECT_EQ(run.stages.detection_ms, 0);
      none_rmse = run.ate.rmse;
    }
    // Same numbers as `dygslam eval` on the same trajectory.
    const CommandOutput eval = RunDygslam("eval --json " + gt + " " + run.trajectory_path);
    ASSERT_EQ(eval.exit_code, 0) << run.trajectory_path;
    EXPECT_NEAR(JsonNumber(eval.stdout_text, "ate_rmse"), run.ate.rmse, 1e-7);
    EXPECT_NEAR(JsonNumber(eval.stdout_text, "ate_mean"), run.ate.mean, 1e-7);
    EXPECT_NEAR(JsonNumber(eval.stdout_text, "ate_sd"), run.ate.sd, 1e-7);
    EXPECT_EQ(JsonNumber(eval.stdout_text, "pairs"), run.ate_pairs);
    // The report shows them (one run: the median is the run).
    // Rows whose boxes came from detections.txt (not the detector) are marked.
    const bool file_boxes = run.config == "boxes" || run.config == "full";
    const std::string row = "| gen_seq | " + ConfigLabel(run.config) + (file_boxes ? " ‡" : "") +
                            " | " + Fixed4(run.ate.rmse) + " | " + Fixed4(run.ate.mean) + " | " +
                            Fixed4(run.ate.sd) + " | ";
    EXPECT_NE(report.find(row), std::string::npos) << row << "\n" << report;
    // Pictures: per configuration.
    EXPECT_TRUE(NonEmptyFile(out / ("gen_seq_" + run.config + ".png")));
    EXPECT_NE(report.find("(gen_seq_" + run.config + ".png)"), std::string::npos);
  }
  // gamma of the full method in the paper-layout table.
  char gamma[32];
  std::snprintf(gamma, sizeof(gamma), "%.2f %%", Improvement(runs[3].ate.rmse, none_rmse));
  const size_t paper_row = report.find("| gen_seq | " + Fixed4(none_rmse) + " | ");
  ASSERT_NE(paper_row, std::string::npos) << report;
  EXPECT_NE(report.substr(paper_row, report.find('\n', paper_row) - paper_row).find(gamma),
            std::string::npos);
  // Table 3 layout and the context lines.
  for (const char* text : {"ORB feature extraction", "Object detection", "ORB feature matching",
                           "Update geometry probability", "Tracking", "Total time", "frames/s",
                           "peak memory", "load average", "--quick mode"}) {
    EXPECT_NE(report.find(text), std::string::npos) << text;
  }
  EXPECT_TRUE(NonEmptyFile(out / "gen_seq_compare.png"));
  {
    DYGSLAM_REQUIRE_MODELS(models);  // the features picture runs the detector
    EXPECT_TRUE(NonEmptyFile(out / "gen_seq_features.png"));
    EXPECT_NE(report.find("(gen_seq_features.png)"), std::string::npos);
  }

  // --report-only rebuilds the same tables from runs.csv, with the recorded command and load.
  const CommandOutput again =
      RunDygslam("bench " + (root / "data").string() +
                     " --quick --quiet --report-only --no-pictures --out " + out.string(),
                 (root / "stderr2.txt").string());
  ASSERT_EQ(again.exit_code, 0) << ReadText((root / "stderr2.txt").string());
  const std::string rebuilt = ReadText((out / "report.md").string());
  EXPECT_NE(rebuilt.find("--update-benchmarks"), std::string::npos);  // the original command
  EXPECT_NE(rebuilt.find("1/5/15-min"), std::string::npos);
  EXPECT_NE(rebuilt.find("--report-only"), std::string::npos);
  EXPECT_NE(report.find("‡ gen_seq: person boxes read from the sequence's `detections.txt`"),
            std::string::npos);
  for (const BenchRun& run : runs) {
    const bool file_boxes = run.config == "boxes" || run.config == "full";
    EXPECT_NE(rebuilt.find("| gen_seq | " + ConfigLabel(run.config) + (file_boxes ? " ‡" : "") +
                           " | " + Fixed4(run.ate.rmse)),
              std::string::npos)
        << run.config;
  }

  // BENCHMARKS.md: only the marked part changed; links relative to it.
  const std::string bench = ReadText((root / "BENCHMARKS.md").string());
  ASSERT_EQ(bench.compare(0, head.size(), head), 0) << bench;
  ASSERT_GE(bench.size(), tail.size());
  EXPECT_EQ(bench.substr(bench.size() - tail.size()), tail);
  EXPECT_EQ(bench.find("old figures"), std::string::npos);
  EXPECT_NE(bench.find("(out/gen_seq_compare.png)"), std::string::npos);
  EXPECT_NE(bench.find("| gen_seq | " + ConfigLabel("full") + " ‡ | " + Fixed4(runs[3].ate.rmse)),
            std::string::npos);
}

TEST(BenchCommand, BadInputIsNamed) {
  const fs::path root = testing::MakeTempDir("bench_command_bad");
  const std::string err = (root / "stderr.txt").string();
  EXPECT_EQ(
      RunDygslam("bench /nonexistent/dygslam_data --quiet --out " + root.string(), err).exit_code,
      1);
  EXPECT_NE(ReadText(err).find("/nonexistent/dygslam_data: not a directory"), std::string::npos)
      << ReadText(err);
  EXPECT_EQ(
      RunDygslam("bench " + root.string() + " --configs none,bogus --out " + root.string(), err)
          .exit_code,
      2);  // a usage error, checked before any run
  EXPECT_NE(ReadText(err).find("bogus"), std::string::npos) << ReadText(err);
  // A malformed or out-of-range number is a usage error (exit 2), as in every command.
  EXPECT_EQ(RunDygslam("bench " + root.string() + " --runs 0", err).exit_code, 2);
  EXPECT_NE(ReadText(err).find("--runs"), std::string::npos) << ReadText(err);
  // A folder without any sequence.
  EXPECT_EQ(RunDygslam("bench " + root.string() + " --out " + (root / "o").string(), err).exit_code,
            1);
  EXPECT_NE(ReadText(err).find("no sequence found"), std::string::npos) << ReadText(err);
}

// A bench stopped by SIGTERM (a CI job cancelled, Ctrl-C) leaves --update-benchmarks FILE as it
// was: its partial runs never replace the last complete report. It says so and exits 128 + 15.
TEST(BenchCommand, StoppedRunLeavesTheBenchmarksFileAsItWas) {
  const fs::path root = testing::MakeTempDir("bench_stopped");
  SyntheticOptions synth;
  synth.num_frames = 40;
  synth.num_moving_objects = 2;
  synth.seed = 3;
  synth.supersampling = 1;
  WriteSyntheticSequence((root / "data" / "gen_seq").string(), synth);
  const std::string before =
      "# Benchmarks\n<!-- bench:begin -->\nthe last complete figures\n<!-- bench:end -->\n";
  const fs::path file = root / "BENCHMARKS.md";
  WriteFileAtomically(file.string(), before);
  const fs::path out = root / "out";
  const std::string err = (root / "stderr.txt").string();
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    if (!freopen(err.c_str(), "w", stderr) || !freopen("/dev/null", "w", stdout)) _exit(127);
    execl(DYGSLAM_EXECUTABLE, DYGSLAM_EXECUTABLE, "bench", (root / "data").c_str(), "--runs", "3",
          "--out", out.c_str(), "--update-benchmarks", file.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  // Stopped once the second of its runs started (its progress line), i.e. with one run done.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(300);
  int status = 0;
  bool exited = false;
  while (!(exited = waitpid(pid, &status, WNOHANG) == pid) &&
         ReadText(err).find("[bench 2/") == std::string::npos &&
         std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  ASSERT_FALSE(exited) << "bench ended before it could be stopped: " << ReadText(err);
  kill(pid, SIGTERM);
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status)) << ReadText(err);
  EXPECT_EQ(WEXITSTATUS(status), 128 + SIGTERM) << ReadText(err);
  EXPECT_EQ(ReadText(file.string()), before);
  EXPECT_NE(ReadText(err).find("not updated: the runs were stopped by signal 15"),
            std::string::npos)
      << ReadText(err);
}

}  // namespace
}  // namespace dygslam
