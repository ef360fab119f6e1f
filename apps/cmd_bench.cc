// dygslam bench DATA_DIR [--runs N] [--quick] [--out DIR] [--update-benchmarks BENCHMARKS.md] ...
//
// Regenerates the figures of BENCHMARKS.md: every configuration (no filter, box removal only,
// geometry only, full method) and the cv::rgbd::RgbdICPOdometry baseline on every TUM/Bonn
// sequence found in DATA_DIR, N runs each, medians in the layout of the paper's Tables 1-3, and
// the pictures (tools/bench/bench_controller.h). Each run is a child process (`dygslam bench
// --worker CONFIG SEQUENCE_DIR ...`) so its peak memory is its own.
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "apps/command.h"
#include "core/base/child_process.h"
#include "core/base/error.h"
#include "core/base/number_option.h"
#include "core/base/stop_signal.h"
#include "run/run_inputs.h"
#include "tools/bench/bench_controller.h"

namespace dygslam::cli {
namespace {
namespace fs = std::filesystem;

const char* kUsage =
    "DATA_DIR [--runs N] [--quick] [--configs LIST] [--no-baseline] [--frames FIRST:LAST]\n"
    "       [--out DIR] [--work DIR] [--update-benchmarks FILE] [--config FILE] [--deterministic]\n"
    "       [--features-frame K] [--quiet]";

void DefineOptions(ArgParser* parser) {
  ArgParser& p = *parser;
  p.AddPositional("DATA_DIR", "data directory (e.g. ../shared/data) or one sequence folder");
  p.AddOption("runs", "N", "runs per sequence and configuration (median reported)", "5");
  p.AddFlag("quick",
            "development mode: 1 run (unless --runs), 60 frames from the middle (unless --frames)");
  p.AddOption("configs", "LIST",
              "filter configurations, comma-separated: none, boxes, geometry, paper, full and the\n"
              "ablation steps paper+margin, paper+margin+demotion",
              "none,boxes,geometry,full");
  p.AddFlag("no-baseline", "skip the cv::rgbd::RgbdICPOdometry baseline");
  p.AddOption("frames", "FIRST:LAST",
              "rgb.txt entries FIRST (inclusive) to LAST (exclusive) of every sequence");
  p.AddOption("out", "DIR", "report folder (report.md, runs.csv, PNGs)", "out/bench");
  p.AddOption("work", "DIR", "run folders (trajectories, frames.csv); default DIR/runs");
  p.AddOption("update-benchmarks", "FILE",
              "write the report between the bench markers of FILE (a Markdown file outside the "
              "data, e.g. BENCHMARKS.md)");
  p.AddOption(
      "config", "FILE",
      "settings YAML for every sequence (default: camera.yaml in the sequence or a preset)");
  p.AddFlag("deterministic", "fixed seeds, synchronous local mapping (default: real threading)");
  p.AddOption("features-frame", "K",
              "rgb.txt entry drawn in the features picture (default: 70 % into the range)");
  p.AddFlag("no-pictures", "tables only");
  p.AddFlag("report-only",
            "no runs: rebuild report and pictures from DIR/runs.csv of an earlier bench");
  p.AddFlag("quiet", "no progress line");
  p.AddOption("worker", "CONFIG",
              "internal: run one configuration on the sequence DATA_DIR into --out");
  p.AddOption("progress-prefix", "TEXT", "internal: progress line prefix of a worker");
}

int RunBench(const std::vector<std::string>& args) {
  ArgParser p(
      "bench", kUsage,
      "Runs every configuration (none = no filter, our tracker; boxes = box removal\n"
      "only; geometry = geometry only; full = the full method) and the cv::rgbd::RgbdICPOdometry\n"
      "baseline on every TUM/Bonn sequence in DATA_DIR (a sequence folder or a folder of them),\n"
      "N runs each, and writes DIR/report.md (medians: ATE like the paper's Tables 1-2, stage\n"
      "times like Table 3, frames/s, peak memory), DIR/runs.csv (every run) and PNG pictures.\n"
      "--update-benchmarks FILE replaces the text between <!-- bench:begin --> and\n"
      "<!-- bench:end --> in FILE with the report.");
  DefineOptions(&p);
  if (!p.Parse(args)) return p.exit_code();

  if (p.Has("worker")) {
    if (!p.Has("config")) return p.UsageError("--worker needs --config");
    RunBenchWorker({p.Get("worker"), p.Positional("DATA_DIR"), p.Get("config"), p.Get("out"),
                    p.Get("frames"), CliSettingsReadOptions(false), p.Flag("deterministic"),
                    p.Flag("quiet"), p.Get("progress-prefix")});
    return 0;
  }
  // SIGINT / SIGTERM / SIGHUP stop the bench between runs (the current one is left out): the
  // report and runs.csv of the runs done so far are written, exit 0 (like `run` and `map`).
  const ScopedStopSignals stop_signals;
  BenchControllerOptions o;
  o.data_dir = p.Positional("DATA_DIR");
  o.quick = p.Flag("quick");
  o.runs = (o.quick && !p.Has("runs"))
               ? 1
               : static_cast<int>(IntegerOption("runs", p.Get("runs"), 1, 100));
  o.configs.clear();
  for (std::string item, list = p.Get("configs") + ","; !list.empty(); list.erase(0, 1)) {
    if (list[0] != ',') {
      if (list[0] != ' ') item += list[0];
    } else if (!item.empty()) {
      o.configs.push_back(item);
      item.clear();
    }
  }
  if (o.configs.empty()) return p.UsageError("--configs: empty list");
  o.baseline = !p.Flag("no-baseline");
  o.frames = p.Get("frames");
  if (p.Has("features-frame"))
    o.features_frame = IntegerOption("features-frame", p.Get("features-frame"), 0, INT64_MAX);
  o.settings_path = p.Get("config");
  o.update_benchmarks = p.Get("update-benchmarks");
  o.deterministic = p.Flag("deterministic");
  o.pictures = !p.Flag("no-pictures");
  o.report_only = p.Flag("report-only");
  o.quiet = p.Flag("quiet");
  o.settings_read = CliSettingsReadOptions(false);
  o.config_dir = ConfigDir();
  o.plots_script = ScriptsDir() + "/bench_plots.py";
  o.worker_executable = fs::read_symlink("/proc/self/exe").string();
  o.command_line = "dygslam bench";
  for (const std::string& a : args) o.command_line += " " + ShellQuote(a);
  o.warn_about_dataset = [](const RgbdDataset& dataset, size_t first, size_t last,
                            const SystemOptions& system, const std::vector<StampedPose>& truth) {
    WarnAboutDataset("bench", dataset, first, last, system.sensor.depth_map_factor,
                     system.camera.width, system.camera.height, &truth);
  };
  // Checked before any run (named by the option; not a filesystem error after the first run).
  o.out_dir = fs::absolute(PrepareOutputDir("out", p.Get("out"))).lexically_normal().string();
  o.work_dir = fs::absolute(p.Has("work") ? PrepareOutputDir("work", p.Get("work"))
                                          : PrepareOutputDir("out", o.out_dir + "/runs"))
                   .lexically_normal()
                   .string();
  BenchController bench(o);
  if (const std::string why = bench.FindUsageProblem(); !why.empty()) return p.UsageError(why);
  const BenchSummary& summary = bench.Run();
  if (!summary.cells.empty() || summary.exit_code == 0)
    std::fputs(BenchSummaryText(summary).c_str(), stdout);
  return summary.exit_code;
}

const CommandRegistrar kRegistrar({"bench",
                                   "benchmark the configurations and a baseline (BENCHMARKS.md)",
                                   RunBench});

}  // namespace
}  // namespace dygslam::cli
