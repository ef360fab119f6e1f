// dygslam bench DATA_DIR [--runs N] [--quick] [--out DIR] [--update-benchmarks BENCHMARKS.md] ...
//
// Regenerates the figures of BENCHMARKS.md: every configuration (no filter, box removal only,
// geometry only, full method) and the cv::rgbd::RgbdICPOdometry baseline on every TUM/Bonn
// sequence found in DATA_DIR, N runs each, medians in the layout of the paper's Tables 1-3, and
// the pictures. Each run is a child process (`dygslam bench --worker CONFIG SEQUENCE_DIR ...`) so
// its peak memory is its own (wait4 rusage).
#include <signal.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "apps/command.h"
#include "core/base/echo.h"
#include "core/base/error.h"
#include "core/base/json.h"
#include "core/base/number_option.h"
#include "core/base/stop_signal.h"
#include "core/config/settings.h"
#include "core/eval/trajectory_eval.h"
#include "core/io/dataset.h"
#include "core/io/file_util.h"
#include "core/io/trajectory_io.h"
#include "core/system/system.h"
#include "run/run_settings.h"
#include "run/system_config.h"
#include "tools/bench/bench_report.h"
#include "tools/bench/bench_runner.h"
#include "tools/bench/bench_sequences.h"
#include "tools/bench/feature_figure.h"
#include "tools/bench/rgbd_odometry_baseline.h"

#ifndef DYGSLAM_VERSION
#define DYGSLAM_VERSION "unknown"
#endif

extern char** environ;

namespace dygslam::cli {
namespace {
namespace fs = std::filesystem;

const char* kUsage =
    "DATA_DIR [--runs N] [--quick] [--configs LIST] [--no-baseline] [--frames FIRST:LAST]\n"
    "       [--out DIR] [--work DIR] [--update-benchmarks FILE] [--config FILE] [--deterministic]\n"
    "       [--features-frame K] [--quiet]";

std::string ReadFirstLine(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  return line;
}

std::string LoadAverages() {
  std::istringstream in(ReadFirstLine("/proc/loadavg"));
  std::string a, b, c;
  in >> a >> b >> c;
  return a.empty() ? "n/a" : a + " / " + b + " / " + c;
}

double LoadAverage1() {
  std::istringstream in(ReadFirstLine("/proc/loadavg"));
  double a = -1;
  in >> a;
  return a;
}

std::string MachineDescription() {
  std::string model;
  std::ifstream cpuinfo("/proc/cpuinfo");
  for (std::string line; std::getline(cpuinfo, line);) {
    if (line.rfind("model name", 0) == 0) {
      model = line.substr(line.find(':') + 1);
      model.erase(0, model.find_first_not_of(' '));
      break;
    }
  }
  double mem_gib = 0;
  std::ifstream meminfo("/proc/meminfo");
  for (std::string line; std::getline(meminfo, line);) {
    if (line.rfind("MemTotal:", 0) == 0) {
      mem_gib = std::atof(line.substr(9).c_str()) / (1024.0 * 1024.0);
      break;
    }
  }
  char buf[256];
  std::snprintf(buf, sizeof(buf), "%s, %u CPU cores, %.0f GiB RAM",
                model.empty() ? "unknown CPU" : model.c_str(), std::thread::hardware_concurrency(),
                mem_gib);
  return buf;
}

std::string UtcNow() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char buf[64];
  std::strftime(buf, sizeof(buf), "%Y-%m-%d %H:%M UTC", &tm);
  return buf;
}

std::string Duration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "?";
  const int s = static_cast<int>(seconds + 0.5);
  char buf[32];
  if (s >= 3600) {
    std::snprintf(buf, sizeof(buf), "%d:%02d:%02d", s / 3600, (s / 60) % 60, s % 60);
  } else {
    std::snprintf(buf, sizeof(buf), "%d:%02d", s / 60, s % 60);
  }
  return buf;
}

std::string SelfExecutable() {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (ec) throw std::runtime_error("cannot resolve /proc/self/exe");
  return exe.string();
}

struct ChildResult {
  int exit_code = -1;
  double peak_rss_mib = 0;
};

// Runs `args` (args[0] = program) as a child process and waits; peak memory from wait4.
ChildResult RunChild(const std::vector<std::string>& args) {
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  pid_t pid = 0;
  if (posix_spawn(&pid, argv[0], nullptr, nullptr, argv.data(), environ) != 0)
    throw std::runtime_error("cannot start " + args[0]);
  int status = 0;
  struct rusage usage {};
  // A stop signal to the bench (Ctrl-C reaches the worker too; `kill PID` only the bench) is
  // passed on to the worker once: it ends, and the bench writes the report of the runs before.
  bool forwarded = false;
  for (;;) {
    const int sig = ScopedStopSignals::Received();
    if (sig != 0 && !forwarded) {
      ::kill(pid, sig);
      forwarded = true;
    }
    if (wait4(pid, &status, 0, &usage) >= 0) break;
    if (errno != EINTR) throw std::runtime_error("wait4 failed");
  }
  ChildResult r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  r.peak_rss_mib = usage.ru_maxrss / 1024.0;  // Linux: kilobytes
  return r;
}

std::vector<std::string> SplitList(const std::string& text) {
  std::vector<std::string> out;
  std::string cur;
  for (char c : text + ",") {
    if (c == ',') {
      if (!cur.empty()) out.push_back(cur);
      cur.clear();
    } else if (c != ' ') {
      cur += c;
    }
  }
  return out;
}

// --- worker: one run in this process ------------------------------------------------------

int RunWorker(const ArgParser& p) {
  const std::string config = p.Get("worker");
  const std::string dataset_dir = p.Positional("DATA_DIR");
  if (!p.Has("config")) return p.UsageError("--worker needs --config");
  // The baseline reads only the camera; its name is no filter configuration.
  const RunConfiguration c = LoadRunConfiguration(
      {p.Get("config"), CliSettingsReadOptions(false),
       config == kBaselineConfig ? std::string("full") : config, p.Flag("deterministic")});
  const RgbdDataset dataset = RgbdDataset::Open(dataset_dir);
  size_t first = 0, last = dataset.num_rgb_entries();
  if (p.Has("frames")) std::tie(first, last) = ParseFrameRange(p.Get("frames"), last);
  const std::string prefix = p.Get("progress-prefix");
  const bool progress = !p.Flag("quiet");
  const auto t0 = std::chrono::steady_clock::now();
  RunProgress report = [&](size_t done, size_t total) {
    if (!progress || (done % 10 != 0 && done != total)) return;
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::fprintf(stderr, "\r%s frame %zu/%zu (%.1f fps)   ", prefix.c_str(), done, total,
                 done / std::max(s, 1e-9));
    std::fflush(stderr);
  };
  RunOutput output;
  if (config == kBaselineConfig) {
    output = RunOdometryOnSequence(dataset, c.settings.camera, c.settings.sensor.depth_map_factor,
                                   RgbdOdometryOptions(), first, last, report);
  } else {
    output = RunSystemOnSequence(dataset, c.system, first, last, report);
  }
  WriteRunOutput(p.Get("out"), output);
  return 0;
}

// --- pictures -------------------------------------------------------------------------------

// "t gt_x gt_y gt_z est_x est_y est_z error" per associated pair (scripts/plot_trajectory.py).
void WritePairs(const std::string& path, const AteResult& ate) {
  WriteFileAtomically(path, AtePairsText(ate));
}

std::string SafeName(const std::string& s) {
  std::string out;
  for (char c : s)
    out += (std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_') ? c : '_';
  return out;
}

// --- the benchmark --------------------------------------------------------------------------

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
  p.AddPositional("DATA_DIR", "data directory (e.g. ../shared/data) or one sequence folder");
  p.AddOption("runs", "N", "runs per sequence and configuration (median reported)", "5");
  p.AddFlag("quick",
            "development mode: 1 run (unless --runs), 60 frames from the middle (unless --frames)");
  p.AddOption("configs", "LIST", "filter configurations, comma-separated",
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
  if (!p.Parse(args)) return p.exit_code();
  if (p.Has("worker")) return RunWorker(p);
  // SIGINT / SIGTERM / SIGHUP stop the bench between runs (the current one is left out): the
  // report and runs.csv of the runs done so far are written, exit 0 (like `run` and `map`).
  ScopedStopSignals stop_signals;

  const auto t_start = std::chrono::steady_clock::now();
  const bool quick = p.Flag("quick");
  const int runs = (quick && !p.Has("runs"))
                       ? 1
                       : static_cast<int>(IntegerOption("runs", p.Get("runs"), 1, 100));
  std::vector<std::string> configs = SplitList(p.Get("configs"));
  if (configs.empty()) return p.UsageError("--configs: empty list");
  for (const std::string& c : configs) {  // an unknown name is a usage error naming --configs
    SystemOptions check;
    try {
      ApplyFilterConfiguration(c, &check);
    } catch (const InvalidOptions& e) {
      return p.UsageError(std::string("--configs: ") + e.what());
    }
  }
  std::vector<std::string> all_configs = configs;
  if (!p.Flag("no-baseline")) all_configs.push_back(kBaselineConfig);
  const bool quiet = p.Flag("quiet");
  const bool deterministic = p.Flag("deterministic");

  // Checked before any run (named by the option; not a filesystem error after the first run).
  const fs::path out_dir = fs::absolute(PrepareOutputDir("out", p.Get("out"))).lexically_normal();
  // Where --out is now (renamed away mid-run: the folder the bench started with), for the
  // pictures the plotting script writes by path.
  const auto PinnedOutDir = [&] { return fs::path(PinnedFolderNow(out_dir.string())); };
  const fs::path work_dir =
      fs::absolute(p.Has("work") ? PrepareOutputDir("work", p.Get("work"))
                                 : PrepareOutputDir("out", (out_dir / "runs").string()))
          .lexically_normal();

  // The file the section goes into: a Markdown file outside any dataset, never one of this
  // bench's own outputs (the report would be written over it first); its markers checked now,
  // not after the runs.
  if (p.Has("update-benchmarks")) {
    const std::string target = p.Get("update-benchmarks");
    const std::string extension = fs::path(target).extension().string();
    if (extension != ".md" && extension != ".markdown")
      return p.UsageError("--update-benchmarks " + target +
                          ": not a Markdown file (.md); the section is written into a report "
                          "such as BENCHMARKS.md");
    if (const std::string dataset = DatasetFolderOf(target); !dataset.empty())
      return p.UsageError("--update-benchmarks " + target + " is a file of the dataset " + dataset +
                          "; a bench never writes into its data");
    std::vector<NamedPath> outputs;
    for (const char* name : {"report.md", "runs.csv", "bench_context.txt"})
      outputs.push_back({std::string("the output ") + name, (out_dir / name).string()});
    if (const std::string clash = FindOutputClash({{"--update-benchmarks", target}}, outputs);
        !clash.empty())
      return p.UsageError(clash);
    std::ifstream in(target);
    if (!in) throw InputError(target, 0, "--update-benchmarks: cannot read");
    std::stringstream text;
    text << in.rdbuf();
    ReplaceBetweenMarkers(text.str(), "", target);  // throws naming the file and the marker
    PinFolderOfOutput(target);
  }

  // An earlier bench's report, runs and pictures in --out are replaced, never a user's files
  // of the same names.
  {
    const std::vector<std::array<std::string, 3>> kinds = {
        {"report.md", "# dygslam bench report", "a bench report"},
        {"runs.csv", "sequence,config,run,", "a bench's runs.csv"},
        {"bench_context.txt", "command: ", "a bench's context file"}};
    for (const auto& [name, signature, kind] : kinds) {
      if (const std::string foreign = FindForeignFileAtOutput(
              {"the output " + name, (out_dir / name).string()}, signature, kind);
          !foreign.empty())
        return p.UsageError(foreign);
    }
    std::error_code ec;
    for (const auto& entry : fs::directory_iterator(out_dir, ec)) {
      if (entry.path().extension() != ".png") continue;
      if (const std::string foreign = FindForeignFileAtOutput(
              {"the picture " + entry.path().filename().string(), entry.path().string()},
              "\x89PNG\r\n\x1a\n", "a PNG picture");
          !foreign.empty())
        return p.UsageError(foreign);
    }
  }

  const std::string config_dir = (fs::path(ScriptsDir()).parent_path() / "config").string();
  std::vector<std::string> skipped;
  const std::vector<BenchSequence> sequences =
      FindBenchSequences(p.Positional("DATA_DIR"), config_dir, p.Get("config"), &skipped);
  for (const std::string& s : skipped) std::cerr << "dygslam bench: skipped " << s << "\n";
  if (sequences.empty())
    throw InputError(p.Positional("DATA_DIR"), 0,
                     "no sequence found (a folder with rgb.txt, depth.txt and groundtruth.txt)");

  // None of this bench's inputs (a dataset's lists, a settings file) is --update-benchmarks.
  if (p.Has("update-benchmarks")) {
    std::vector<NamedPath> inputs;
    if (p.Has("config")) inputs.push_back({"--config", p.Get("config")});
    for (const BenchSequence& s : sequences) {
      inputs.push_back({"the settings of " + s.name, s.settings_path});
      for (const char* list : {"rgb.txt", "depth.txt", "groundtruth.txt", "associations.txt"})
        inputs.push_back(
            {std::string(list) + " of " + s.name, (fs::path(s.directory) / list).string()});
    }
    if (const std::string clash =
            FindOutputClash(inputs, {{"--update-benchmarks", p.Get("update-benchmarks")}});
        !clash.empty())
      return p.UsageError(clash);
  }

  // Per sequence: settings, dataset, frame range, ground truth (all checked before any run).
  struct Prepared {
    BenchSequence sequence;
    Settings settings;
    size_t first = 0, last = 0;
    std::vector<StampedPose> groundtruth;
    size_t num_entries = 0;
  };
  std::vector<Prepared> prepared;
  for (const BenchSequence& s : sequences) {
    Prepared pr;
    pr.sequence = s;
    pr.settings = LoadSettings(s.settings_path, CliSettingsReadOptions(false));
    const RgbdDataset dataset = RgbdDataset::Open(s.directory);
    pr.num_entries = dataset.num_rgb_entries();
    pr.last = pr.num_entries;
    // --features-frame is used after every run: checked now (a usage error naming it).
    if (p.Has("features-frame"))
      IntegerOption("features-frame", p.Get("features-frame"), 0,
                    static_cast<int64_t>(pr.num_entries) - 1);
    if (p.Has("frames")) {
      std::tie(pr.first, pr.last) = ParseFrameRange(p.Get("frames"), pr.num_entries);
    } else if (quick && pr.num_entries > 60) {
      pr.first = pr.num_entries / 2 - 30;
      pr.last = pr.first + 60;
    }
    pr.groundtruth = ReadTumTrajectory(dataset.groundtruth_path());
    {
      const SystemOptions options = SystemOptionsFromSettings(pr.settings);
      WarnAboutDataset("bench", dataset, pr.first, pr.last, options.sensor.depth_map_factor,
                       options.camera.width, options.camera.height, &pr.groundtruth);
    }
    std::error_code ec;
    if (fs::is_regular_file(fs::path(s.directory) / "detections.txt", ec))
      std::cerr << "dygslam bench: " << s.name << ": person boxes from " << s.directory
                << "/detections.txt (not the detector); its box rows are marked ‡ in the report\n";
    prepared.push_back(std::move(pr));
  }

  // Runs: for each sequence, run k of every configuration before run k+1 (load changes spread
  // evenly over the configurations).
  const std::string self = SelfExecutable();
  const int total_jobs = static_cast<int>(prepared.size() * runs * all_configs.size());
  int runs_left_out = 0;  // workers that failed or left unreadable outputs
  int done_jobs = 0;
  std::vector<BenchRun> all_runs;
  std::vector<std::string> notes;
  std::vector<double> load_samples;
  const std::string load_start = LoadAverages();
  std::string load_text;
  std::map<std::string, std::string> recorded;
  const bool report_only = p.Flag("report-only");
  if (report_only) {
    all_runs = ReadBenchRunsCsv((out_dir / "runs.csv").string());
    if (all_runs.empty())
      throw InputError((out_dir / "runs.csv").string(), 0,
                       "holds no run (empty, or its header only): nothing to report from");
    // The context of the bench that measured the runs (written next to runs.csv).
    std::ifstream meta(out_dir / "bench_context.txt");
    for (std::string line; std::getline(meta, line);) {
      const size_t colon = line.find(": ");
      if (colon == std::string::npos) continue;
      recorded[line.substr(0, colon)] = line.substr(colon + 2);
    }
    load_text = recorded.count("load") ? recorded["load"] : "not recorded";
  }
  int stopped_by = 0;  // the stop signal that ended the runs early
  for (const Prepared& pr : prepared) {
    for (int run = 0; run < runs && !report_only && stopped_by == 0; ++run) {
      for (const std::string& config : all_configs) {
        if ((stopped_by = ScopedStopSignals::Received()) != 0) break;
        const fs::path run_dir =
            work_dir / SafeName(pr.sequence.name) / (config + "_" + std::to_string(run));
        fs::remove_all(run_dir);
        const double elapsed =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
        const double eta =
            done_jobs > 0 ? elapsed / done_jobs * (total_jobs - done_jobs) : std::nan("");
        char prefix[512];
        std::snprintf(prefix, sizeof(prefix),
                      "[bench %d/%d, %s elapsed, ETA %s] %s %s run %d/%d:", done_jobs + 1,
                      total_jobs, Duration(elapsed).c_str(), Duration(eta).c_str(),
                      pr.sequence.name.c_str(), config.c_str(), run + 1, runs);
        load_samples.push_back(LoadAverage1());
        std::vector<std::string> cmd = {self,
                                        "bench",
                                        pr.sequence.directory,
                                        "--worker",
                                        config,
                                        "--config",
                                        pr.sequence.settings_path,
                                        "--out",
                                        run_dir.string(),
                                        "--frames",
                                        std::to_string(pr.first) + ":" + std::to_string(pr.last),
                                        "--progress-prefix",
                                        prefix};
        if (deterministic) cmd.push_back("--deterministic");
        if (quiet) cmd.push_back("--quiet");
        const ChildResult child = RunChild(cmd);
        ++done_jobs;
        if ((stopped_by = ScopedStopSignals::Received()) != 0) {
          // The worker was stopped mid-run: its outputs cover part of the frames only.
          const std::string note = pr.sequence.name + " " + config + " run " +
                                   std::to_string(run + 1) + ": interrupted (signal " +
                                   std::to_string(stopped_by) + "), run left out";
          std::cerr << "\ndygslam bench: " << note << "\n";
          notes.push_back(note);
          break;
        }
        if (child.exit_code != 0) {
          const std::string note = pr.sequence.name + " " + config + " run " +
                                   std::to_string(run + 1) + ": worker failed (exit code " +
                                   std::to_string(child.exit_code) + "), run left out";
          std::cerr << "\ndygslam bench: " << note << "\n";
          notes.push_back(note);
          ++runs_left_out;
          continue;
        }
        BenchRun scored;
        try {
          scored = ScoreRun(run_dir.string(), pr.groundtruth);
        } catch (const InputError& e) {
          const std::string note = pr.sequence.name + " " + config + " run " +
                                   std::to_string(run + 1) + ": outputs unreadable (" + e.what() +
                                   "), run left out";
          std::cerr << "\ndygslam bench: " << note << "\n";
          notes.push_back(note);
          ++runs_left_out;
          continue;
        }
        scored.sequence = pr.sequence.name;
        scored.config = config;
        scored.run = run;
        scored.peak_rss_mib = child.peak_rss_mib;
        if (!quiet) {
          std::fprintf(stderr, "\r%s ATE RMSE %.4f m, %.1f fps, %.0f MiB%-20s\n", prefix,
                       scored.ate.rmse, scored.fps, scored.peak_rss_mib, "");
        }
        all_runs.push_back(std::move(scored));
      }
    }
  }
  if (stopped_by != 0 && all_runs.empty()) {
    std::cerr << "dygslam bench: stopped by signal " << stopped_by
              << " before any run ended: no report written\n";
    return 128 + stopped_by;
  }
  if (stopped_by != 0) {
    const std::string note = "stopped by signal " + std::to_string(stopped_by) + " after " +
                             std::to_string(all_runs.size()) + " of " + std::to_string(total_jobs) +
                             " runs: the report holds those";
    std::cerr << "dygslam bench: " << note << "\n";
    notes.push_back(note);
  }
  if (!report_only) {
    double load_mean = 0;
    for (double v : load_samples) load_mean += v;
    if (!load_samples.empty()) load_mean /= load_samples.size();
    char load[256];
    std::snprintf(load, sizeof(load), "1/5/15-min %s at the start, %s at the end; 1-min mean %.2f",
                  load_start.c_str(), LoadAverages().c_str(), load_mean);
    load_text = load;
    WriteFileAtomically((out_dir / "runs.csv").string(), BenchRunsCsv(all_runs));
    std::string command_line = "dygslam bench";
    for (const std::string& a : args) command_line += " " + ShellQuote(a);
    WriteFileAtomically(
        (out_dir / "bench_context.txt").string(),
        "command: " + command_line + "\nload: " + load_text + "\ndate: " + UtcNow() + "\n");
  }

  // Medians.
  std::vector<BenchCell> cells;
  std::map<std::pair<std::string, std::string>, std::vector<const BenchRun*>> grouped;
  for (const Prepared& pr : prepared) {
    for (const std::string& config : all_configs) {
      std::vector<BenchRun> group;
      for (const BenchRun& r : all_runs)
        if (r.sequence == pr.sequence.name && r.config == config) group.push_back(r);
      if (group.empty()) continue;
      BenchCell cell = Summarize(group);
      if (cell.num_failed > 0)
        notes.push_back(pr.sequence.name + " " + config + ": " + std::to_string(cell.num_failed) +
                        " of " + std::to_string(cell.num_runs) +
                        " runs without an ATE (fewer than 3 poses) left out of the medians");
      cells.push_back(cell);
      for (const BenchRun& r : all_runs)
        if (r.sequence == pr.sequence.name && r.config == config)
          grouped[{r.sequence, config}].push_back(&r);
    }
  }

  // γ on the same frame set: the no-filter runs' ATE over each configuration's frames.
  for (BenchCell& cell : cells) {
    if (cell.config == kNoFilterConfig || cell.median_run < 0) continue;
    const auto none_runs = grouped.find({cell.sequence, kNoFilterConfig});
    if (none_runs == grouped.end()) continue;
    const Prepared* pr = nullptr;
    for (const Prepared& candidate : prepared)
      if (candidate.sequence.name == cell.sequence) pr = &candidate;
    if (!pr) continue;
    try {
      std::vector<std::vector<StampedPose>> none_trajectories;
      for (const BenchRun* r : none_runs->second)
        none_trajectories.push_back(ReadTumTrajectory(r->trajectory_path));
      const BenchRun& median = *grouped[{cell.sequence, cell.config}][cell.median_run];
      SetReferenceAte(pr->groundtruth, none_trajectories, ReadTumTrajectory(median.trajectory_path),
                      &cell);
    } catch (const InputError& e) {  // --report-only after the run folders were removed
      notes.push_back(cell.sequence + " " + cell.config +
                      ": γ against the no-filter ATE over all its frames (" + e.what() + ")");
    }
  }

  // Pictures.
  std::vector<SequencePictures> pictures;
  if (!p.Flag("no-pictures")) {
    std::ostringstream manifest;
    manifest << "{\"sequences\": [";
    bool first_seq = true;
    for (const Prepared& pr : prepared) {
      SequencePictures pics;
      pics.sequence = pr.sequence.name;
      const std::string base = SafeName(pr.sequence.name);
      std::ostringstream series;
      bool first_series = true;
      for (const BenchCell& cell : cells) {
        if (cell.sequence != pr.sequence.name) continue;
        const BenchRun& run = *grouped[{cell.sequence, cell.config}][cell.median_run];
        if (!std::isfinite(run.ate.rmse)) continue;
        const std::string pairs = (work_dir / base / (cell.config + "_median_pairs.txt")).string();
        try {
          fs::create_directories(work_dir / base);
          WritePairs(pairs, ComputeAte(pr.groundtruth, ReadTumTrajectory(run.trajectory_path)));
        } catch (const InputError& e) {  // --report-only after the run folders were removed
          notes.push_back(cell.sequence + " " + cell.config + ": picture skipped: " + e.what());
          std::cerr << "dygslam bench: picture skipped: " << e.what() << "\n";
          continue;
        }
        const std::string png = base + "_" + cell.config + ".png";
        pics.config_pngs[cell.config] = png;
        series << (first_series ? "" : ", ") << "{\"config\": " << JsonString(cell.config)
               << ", \"label\": " << JsonString(ConfigLabel(cell.config))
               << ", \"pairs\": " << JsonString(pairs)
               << ", \"png\": " << JsonString((PinnedOutDir() / png).string()) << "}";
        first_series = false;
      }
      if (!first_series) pics.comparison_png = base + "_compare.png";
      manifest << (first_seq ? "" : ", ") << "{\"sequence\": " << JsonString(pr.sequence.name)
               << ", \"compare_png\": "
               << JsonString((PinnedOutDir() / pics.comparison_png).string()) << ", \"series\": ["
               << series.str() << "]}";
      first_seq = false;

      // Features picture (needs the detector model).
      try {
        const RgbdDataset dataset = RgbdDataset::Open(pr.sequence.directory);
        size_t entry = pr.first + static_cast<size_t>(0.7 * (pr.last - pr.first));
        if (p.Has("features-frame")) {
          entry = static_cast<size_t>(IntegerOption("features-frame", p.Get("features-frame"), 0,
                                                    static_cast<int64_t>(pr.num_entries) - 1));
        }
        while (entry > pr.first && !dataset.FrameForRgbEntry(entry)) --entry;
        SystemOptions options = SystemOptionsFromSettings(pr.settings);
        const FeatureFigure figure = DrawFeatureFigure(dataset, entry, options);
        const std::string png = base + "_features.png";
        std::vector<uchar> encoded;
        if (!cv::imencode(".png", figure.image, encoded))
          throw InputError((out_dir / png).string(), 0, "cannot encode PNG");
        WriteFileAtomically((out_dir / png).string(), std::string(encoded.begin(), encoded.end()));
        pics.features_png = png;
        pics.features_caption = figure.caption;
      } catch (const InputError& e) {
        notes.push_back(pr.sequence.name + ": features picture skipped: " + e.what());
        std::cerr << "dygslam bench: features picture skipped: " << e.what() << "\n";
      } catch (const InvalidOptions& e) {
        notes.push_back(pr.sequence.name + ": features picture skipped: " + e.what());
        std::cerr << "dygslam bench: features picture skipped: " << e.what() << "\n";
      }
      pictures.push_back(pics);
    }
    manifest << "]}\n";
    const std::string manifest_path = (work_dir / "plots.json").string();
    WriteFileAtomically(manifest_path, manifest.str());
    const std::string script = ScriptsDir() + "/bench_plots.py";
    const std::string cmd =
        "python3 " + ShellQuote(script) + " --manifest " + ShellQuote(manifest_path);
    const int status = std::system(cmd.c_str());
    const int code = (status != -1 && WIFEXITED(status)) ? WEXITSTATUS(status) : -1;
    if (code != 0) {
      const std::string why = code == 3 ? "python3-matplotlib is not installed"
                                        : "bench_plots.py exit code " + std::to_string(code);
      std::cerr << "dygslam bench: trajectory pictures skipped: " << why << "\n";
      notes.push_back("trajectory pictures skipped: " + why);
      for (SequencePictures& pics : pictures) {
        pics.comparison_png.clear();
        pics.config_pngs.clear();
      }
    }
  }

  // Report.
  BenchContext context;
  std::string command_line = "dygslam bench";
  for (const std::string& a : args) command_line += " " + ShellQuote(a);
  context.command_line = command_line;
  context.date = UtcNow();
  if (report_only) {
    if (recorded.count("command")) context.command_line = recorded["command"];
    if (recorded.count("date")) context.date = recorded["date"];
    int max_run = -1;
    for (const BenchRun& r : all_runs) max_run = std::max(max_run, r.run);
    context.runs = max_run + 1;
    notes.push_back("report rebuilt with --report-only from runs.csv");
  }
  context.machine = MachineDescription();
  context.load = load_text;
  context.version = DYGSLAM_VERSION;
  context.data_dir = p.Positional("DATA_DIR");
  if (!report_only) context.runs = runs;
  context.quick = quick;
  context.deterministic = deterministic;
  context.frames = p.Has("frames") ? "rgb.txt entries " + p.Get("frames")
                                   : (quick ? "at most 60 from the middle of each sequence" : "");
  context.configs = all_configs;
  for (const Prepared& pr : prepared) {
    std::error_code ec;
    if (fs::is_regular_file(fs::path(pr.sequence.directory) / "detections.txt", ec))
      context.file_detection_sequences.push_back(pr.sequence.name);
  }
  for (const std::string& s : skipped) notes.push_back("skipped " + s);
  context.notes = notes;
  const std::string report =
      "# dygslam bench report\n\n" + RenderBenchMarkdown(context, cells, pictures, "") + "\n";
  WriteFileAtomically((out_dir / "report.md").string(), report);
  // Runs cut short by a stop signal give a partial report (OUT/report.md says so): it never
  // replaces the benchmark section of the file, which keeps the last complete one.
  // Likewise runs that failed or left unreadable outputs: the file's section would lose their rows
  // and misstate its run count.
  if (p.Has("update-benchmarks") && stopped_by != 0) {
    std::cerr << "dygslam bench: " << p.Get("update-benchmarks")
              << " not updated: the runs were stopped by signal " << stopped_by
              << " (the partial report is " << (out_dir / "report.md").string() << ")\n";
  } else if (p.Has("update-benchmarks") && runs_left_out > 0) {
    std::cerr << "dygslam bench: " << p.Get("update-benchmarks")
              << " not updated: " << runs_left_out << " of " << total_jobs
              << " runs failed and were left out (the partial report is "
              << (out_dir / "report.md").string() << ")\n";
  } else if (p.Has("update-benchmarks")) {
    const fs::path target = fs::absolute(p.Get("update-benchmarks"));
    std::ifstream in(target);
    if (!in) throw InputError(target.string(), 0, "cannot read");
    std::stringstream text;
    text << in.rdbuf();
    std::string prefix = fs::relative(out_dir, target.parent_path()).generic_string();
    prefix = (prefix.empty() || prefix == ".") ? "" : prefix + "/";
    const std::string updated = ReplaceBetweenMarkers(
        text.str(), RenderBenchMarkdown(context, cells, pictures, prefix), target.string());
    WriteFileAtomically(target.string(), updated);
    std::cout << "updated " << target.string() << "\n";
  }

  // Summary on stdout.
  std::printf("%-24s %-20s %8s %8s %8s %9s %8s %7s\n", "sequence", "configuration", "rmse", "mean",
              "sd", "gamma", "ms/frame", "fps");
  for (const BenchCell& c : cells) {
    double mu = std::nan("");
    for (const BenchCell& n : cells)
      if (n.sequence == c.sequence && n.config == kNoFilterConfig) mu = n.ate.rmse;
    const double gamma = c.config == kNoFilterConfig ? std::nan("") : Improvement(c.ate.rmse, mu);
    char gamma_text[32] = "-";
    if (std::isfinite(gamma)) std::snprintf(gamma_text, sizeof(gamma_text), "%.2f%%", gamma);
    std::printf("%-24s %-20s %8.4f %8.4f %8.4f %9s %8.2f %7.1f\n", c.sequence.c_str(),
                c.config.c_str(), c.ate.rmse, c.ate.mean, c.ate.sd, gamma_text, c.stages.total_ms,
                c.fps);
  }
  std::printf("report: %s\nruns:   %s\n", (out_dir / "report.md").string().c_str(),
              (out_dir / "runs.csv").string().c_str());
  if (p.Has("update-benchmarks") && stopped_by != 0) return 128 + stopped_by;
  if (p.Has("update-benchmarks") && runs_left_out > 0) return 1;
  return notes.empty() || all_runs.size() > 0 ? 0 : 1;
}

const CommandRegistrar kRegistrar({"bench",
                                   "benchmark the configurations and a baseline (BENCHMARKS.md)",
                                   RunBench});

}  // namespace
}  // namespace dygslam::cli
