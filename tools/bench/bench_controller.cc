#include "tools/bench/bench_controller.h"

#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <thread>
#include <tuple>

#include "core/base/child_process.h"
#include "core/base/error.h"
#include "core/base/json.h"
#include "core/base/stop_signal.h"
#include "core/eval/trajectory_eval.h"
#include "core/io/file_util.h"
#include "core/io/trajectory_io.h"
#include "run/run_settings.h"
#include "run/settings_table.h"
#include "run/system_config.h"
#include "tools/bench/bench_configurations.h"
#include "tools/bench/bench_runner.h"
#include "tools/bench/feature_figure.h"

#ifndef DYGSLAM_VERSION
#define DYGSLAM_VERSION "unknown"
#endif

namespace dygslam {
namespace {
namespace fs = std::filesystem;

double SteadySeconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

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

std::string SafeName(const std::string& s) {
  std::string out;
  for (char c : s)
    out += (std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_') ? c : '_';
  return out;
}

std::string ReadWhole(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, "cannot read");
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace

void BenchControllerOptions::Check() const {
  DYGSLAM_CHECK_OPTION(runs >= 1 && runs <= 100, "--runs");
  if (configs.empty()) throw InvalidOptions("--configs: empty list");
  for (const std::string& c : configs) {  // an unknown name is a usage error naming --configs
    try {
      BaseFilterConfiguration(c);
    } catch (const InvalidOptions& e) {
      throw InvalidOptions(std::string("--configs: ") + e.what());
    }
  }
  DYGSLAM_CHECK_OPTION(!out_dir.empty() && !work_dir.empty(), "--out / --work");
  DYGSLAM_CHECK_OPTION(!worker_executable.empty(), "worker_executable");
}

BenchController::BenchController(BenchControllerOptions options) : options_(std::move(options)) {
  options_.Check();
  summary_.report_path = (fs::path(options_.out_dir) / "report.md").string();
  summary_.runs_path = (fs::path(options_.out_dir) / "runs.csv").string();
}

std::vector<std::string> BenchController::AllConfigs() const {
  std::vector<std::string> all = options_.configs;
  if (options_.baseline) all.push_back(kBaselineConfig);
  return all;
}

namespace {
// A settings file given a Markdown name (it may carry the markers in comments): opened by
// `%YAML`, or holding a line that sets a dotted settings key ("Camera.fx: 517.3").
bool LooksLikeSettings(const std::string& text) {
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line)) {
    if (line.rfind("%YAML", 0) == 0) return true;
    size_t i = 0;
    while (i < line.size() && std::isalnum(static_cast<unsigned char>(line[i]))) ++i;
    if (i == 0 || i >= line.size() || line[i] != '.') continue;
    size_t j = i + 1;
    while (j < line.size() &&
           (std::isalnum(static_cast<unsigned char>(line[j])) || line[j] == '_' || line[j] == '.'))
      ++j;
    if (j > i + 1 && j < line.size() && line[j] == ':') return true;
  }
  return false;
}
}  // namespace

std::string BenchController::CheckUpdateFile() const {
  const std::string& target = options_.update_benchmarks;
  const std::string extension = fs::path(target).extension().string();
  if (extension != ".md" && extension != ".markdown")
    return "--update-benchmarks " + target +
           ": not a Markdown file (.md); the section is written into a report such as "
           "BENCHMARKS.md";
  if (const std::string dataset = DatasetFolderOf(target); !dataset.empty())
    return "--update-benchmarks " + target + " is a file of the dataset " + dataset +
           "; a bench never writes into its data";
  std::vector<NamedPath> outputs;
  for (const char* name : {"report.md", "runs.csv", "bench_context.txt"})
    outputs.push_back(
        {std::string("the output ") + name, (fs::path(options_.out_dir) / name).string()});
  if (const std::string clash = FindOutputClash({{"--update-benchmarks", target}}, outputs);
      !clash.empty())
    return clash;
  std::ifstream in(target);
  if (!in) throw InputError(target, 0, "--update-benchmarks: cannot read");
  std::stringstream text;
  text << in.rdbuf();
  if (LooksLikeSettings(text.str()))
    return "--update-benchmarks " + target +
           " is a settings file (YAML with settings keys), not a Markdown report; a bench "
           "never writes into a settings file";
  ReplaceBetweenMarkers(text.str(), "", target);  // throws naming the file and the marker
  PinFolderOfOutput(target);
  return "";
}

std::string BenchController::FindForeignOutput() const {
  const std::vector<std::array<std::string, 3>> kinds = {
      {"report.md", "# dygslam bench report", "a bench report"},
      {"runs.csv", "sequence,config,run,", "a bench's runs.csv"},
      {"bench_context.txt", "command: ", "a bench's context file"}};
  for (const auto& [name, signature, kind] : kinds) {
    if (const std::string foreign = FindForeignFileAtOutput(
            {"the output " + name, (fs::path(options_.out_dir) / name).string()}, signature, kind);
        !foreign.empty())
      return foreign;
  }
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(options_.out_dir, ec)) {
    if (entry.path().extension() != ".png") continue;
    if (const std::string foreign = FindForeignFileAtOutput(
            {"the picture " + entry.path().filename().string(), entry.path().string()},
            "\x89PNG\r\n\x1a\n", "a PNG picture");
        !foreign.empty())
      return foreign;
  }
  return "";
}

std::string BenchController::FindUsageProblem() {
  checked_ = true;
  if (!options_.update_benchmarks.empty()) {
    if (const std::string why = CheckUpdateFile(); !why.empty()) return why;
  }
  if (const std::string why = FindForeignOutput(); !why.empty()) return why;
  return Prepare();
}

// Per sequence: settings, dataset, frame range, ground truth (all checked before any run).
std::string BenchController::Prepare() {
  const std::vector<BenchSequence> sequences =
      FindBenchSequences(options_.data_dir, options_.config_dir, options_.settings_path, &skipped_);
  for (const std::string& s : skipped_) std::cerr << "dygslam bench: skipped " << s << "\n";
  if (sequences.empty())
    throw InputError(options_.data_dir, 0,
                     "no sequence found (a folder with rgb.txt, depth.txt and groundtruth.txt)");
  // None of this bench's inputs (a dataset's lists, a settings file) is --update-benchmarks.
  if (!options_.update_benchmarks.empty()) {
    std::vector<NamedPath> inputs;
    if (!options_.settings_path.empty()) inputs.push_back({"--config", options_.settings_path});
    for (const BenchSequence& s : sequences) {
      inputs.push_back({"the settings of " + s.name, s.settings_path});
      for (const char* list : {"rgb.txt", "depth.txt", "groundtruth.txt", "associations.txt"})
        inputs.push_back(
            {std::string(list) + " of " + s.name, (fs::path(s.directory) / list).string()});
    }
    if (const std::string clash =
            FindOutputClash(inputs, {{"--update-benchmarks", options_.update_benchmarks}});
        !clash.empty())
      return clash;
  }
  for (const BenchSequence& s : sequences) {
    Prepared pr;
    pr.sequence = s;
    pr.settings = LoadSettings(s.settings_path, options_.settings_read);
    const RgbdDataset dataset = RgbdDataset::Open(s.directory);
    pr.num_entries = dataset.num_rgb_entries();
    pr.last = pr.num_entries;
    if (options_.features_frame >= static_cast<int64_t>(pr.num_entries))
      return "--features-frame: out of range, got '" + std::to_string(options_.features_frame) +
             "' (expected 0.." + std::to_string(pr.num_entries - 1) + " for " + s.name + ")";
    if (!options_.frames.empty()) {
      std::tie(pr.first, pr.last) = ParseFrameRange(options_.frames, pr.num_entries);
    } else if (options_.quick && pr.num_entries > 60) {
      pr.first = pr.num_entries / 2 - 30;
      pr.last = pr.first + 60;
    }
    pr.groundtruth = ReadTumTrajectory(dataset.groundtruth_path());
    if (options_.warn_about_dataset)
      options_.warn_about_dataset(dataset, pr.first, pr.last,
                                  SystemOptionsFromSettings(pr.settings), pr.groundtruth);
    std::error_code ec;
    if (fs::is_regular_file(fs::path(s.directory) / "detections.txt", ec))
      std::cerr << "dygslam bench: " << s.name << ": person boxes from " << s.directory
                << "/detections.txt (not the detector); its box rows are marked ‡ in the report\n";
    prepared_.push_back(std::move(pr));
  }
  return "";
}

const BenchSummary& BenchController::Run() {
  if (!checked_) {
    if (const std::string why = FindUsageProblem(); !why.empty()) throw InvalidOptions(why);
  }
  started_ = SteadySeconds();
  summary_.total_runs = static_cast<int>(prepared_.size() * options_.runs * AllConfigs().size());
  if (options_.report_only) {
    ReadEarlierRuns();
  } else {
    RunAll();
  }
  if (summary_.stopped_by != 0 && runs_.empty()) {
    std::cerr << "dygslam bench: stopped by signal " << summary_.stopped_by
              << " before any run ended: no report written\n";
    summary_.exit_code = 128 + summary_.stopped_by;
    return summary_;
  }
  if (summary_.stopped_by != 0) {
    const std::string note = "stopped by signal " + std::to_string(summary_.stopped_by) +
                             " after " + std::to_string(runs_.size()) + " of " +
                             std::to_string(summary_.total_runs) + " runs: the report holds those";
    std::cerr << "dygslam bench: " << note << "\n";
    summary_.notes.push_back(note);
  }
  if (!options_.report_only) WriteRunsCsv();
  ComputeMedians();
  ComputeReferenceAte();
  if (options_.pictures) DrawPictures();
  WriteReports();
  if (summary_.exit_code == 0 && runs_.empty()) summary_.exit_code = 1;  // every run failed
  return summary_;
}

void BenchController::ReadEarlierRuns() {
  runs_ = ReadBenchRunsCsv(summary_.runs_path);
  if (runs_.empty())
    throw InputError(summary_.runs_path, 0,
                     "holds no run (empty, or its header only): nothing to report from");
  // The context of the bench that measured the runs (written next to runs.csv).
  std::ifstream meta(fs::path(options_.out_dir) / "bench_context.txt");
  for (std::string line; std::getline(meta, line);) {
    const size_t colon = line.find(": ");
    if (colon == std::string::npos) continue;
    recorded_[line.substr(0, colon)] = line.substr(colon + 2);
  }
  load_text_ = recorded_.count("load") ? recorded_["load"] : "not recorded";
}

// For each sequence, run k of every configuration before run k+1 (load changes spread evenly
// over the configurations).
void BenchController::RunAll() {
  load_start_ = LoadAverages();
  int done = 0;
  for (const Prepared& pr : prepared_) {
    for (int run = 0; run < options_.runs && summary_.stopped_by == 0; ++run) {
      for (const std::string& config : AllConfigs()) {
        if ((summary_.stopped_by = ScopedStopSignals::Received()) != 0) break;
        RunOne(pr, run, config, &done);
        if (summary_.stopped_by != 0) break;
      }
    }
  }
}

namespace {

// `from` (a complete run folder) in place of `to`: the earlier folder is moved aside first and
// removed only once the new one is in place.
void ReplaceFolder(const fs::path& from, const fs::path& to) {
  const fs::path previous = to.string() + ".previous";
  fs::remove_all(previous);
  if (fs::exists(to)) fs::rename(to, previous);
  fs::rename(from, to);
  fs::remove_all(previous);
}

}  // namespace

void BenchController::RunOne(const Prepared& pr, int run, const std::string& config, int* done) {
  const fs::path run_dir = fs::path(options_.work_dir) / SafeName(pr.sequence.name) /
                           (config + "_" + std::to_string(run));
  // The worker writes into a folder of its own; it replaces an earlier bench's run folder only
  // once the run is complete (a stopped or failed run leaves the earlier one as it was).
  const fs::path partial_dir = run_dir.string() + ".partial";
  fs::remove_all(partial_dir);
  const double elapsed = SteadySeconds() - started_;
  const double eta = *done > 0 ? elapsed / *done * (summary_.total_runs - *done) : std::nan("");
  char prefix[512];
  std::snprintf(prefix, sizeof(prefix),
                "[bench %d/%d, %s elapsed, ETA %s] %s %s run %d/%d:", *done + 1,
                summary_.total_runs, Duration(elapsed).c_str(), Duration(eta).c_str(),
                pr.sequence.name.c_str(), config.c_str(), run + 1, options_.runs);
  load_samples_.push_back(LoadAverage1());
  ChildProcessOptions worker;
  worker.argv = {options_.worker_executable,
                 "bench",
                 pr.sequence.directory,
                 "--worker",
                 config,
                 "--config",
                 pr.sequence.settings_path,
                 "--out",
                 partial_dir.string(),
                 "--frames",
                 std::to_string(pr.first) + ":" + std::to_string(pr.last),
                 "--progress-prefix",
                 prefix};
  if (options_.deterministic) worker.argv.push_back("--deterministic");
  if (options_.quiet) worker.argv.push_back("--quiet");
  // A stop signal to the bench (Ctrl-C reaches the worker too; `kill PID` only the bench) is
  // passed on to the worker: it ends, and the bench writes the report of the runs before.
  const ChildExit child = WaitForChildProcess(StartChildProcess(worker), true);
  ++*done;
  const std::string name =
      pr.sequence.name + " " + config + " run " + std::to_string(run + 1) + ": ";
  const auto leave_out = [&](const std::string& why) {
    std::cerr << "\ndygslam bench: " << name << why << "\n";
    summary_.notes.push_back(name + why);
  };
  if ((summary_.stopped_by = ScopedStopSignals::Received()) != 0) {
    // The worker was stopped mid-run: its outputs cover part of the frames only.
    fs::remove_all(partial_dir);
    leave_out("interrupted (signal " + std::to_string(summary_.stopped_by) + "), run left out");
    return;
  }
  if (child.exit_code != 0) {
    fs::remove_all(partial_dir);
    leave_out("worker failed (exit code " + std::to_string(child.exit_code) + "), run left out");
    ++summary_.runs_left_out;
    return;
  }
  ReplaceFolder(partial_dir, run_dir);
  BenchRun scored;
  try {
    scored = ScoreRun(run_dir.string(), pr.groundtruth);
  } catch (const InputError& e) {
    leave_out(std::string("outputs unreadable (") + e.what() + "), run left out");
    ++summary_.runs_left_out;
    return;
  }
  scored.sequence = pr.sequence.name;
  scored.config = config;
  scored.run = run;
  scored.peak_rss_mib = child.peak_rss_mib;
  if (!options_.quiet) {
    std::fprintf(stderr, "\r%s ATE RMSE %.4f m, %.1f fps, %.0f MiB%-20s\n", prefix, scored.ate.rmse,
                 scored.fps, scored.peak_rss_mib, "");
  }
  runs_.push_back(std::move(scored));
}

void BenchController::WriteRunsCsv() {
  double load_mean = 0;
  for (double v : load_samples_) load_mean += v;
  if (!load_samples_.empty()) load_mean /= load_samples_.size();
  char load[256];
  std::snprintf(load, sizeof(load), "1/5/15-min %s at the start, %s at the end; 1-min mean %.2f",
                load_start_.c_str(), LoadAverages().c_str(), load_mean);
  load_text_ = load;
  WriteFileAtomically(summary_.runs_path, BenchRunsCsv(runs_));
  WriteFileAtomically(
      (fs::path(options_.out_dir) / "bench_context.txt").string(),
      "command: " + options_.command_line + "\nload: " + load_text_ + "\ndate: " + UtcNow() + "\n");
}

void BenchController::ComputeMedians() {
  for (const Prepared& pr : prepared_) {
    for (const std::string& config : AllConfigs()) {
      std::vector<BenchRun> group;
      for (const BenchRun& r : runs_)
        if (r.sequence == pr.sequence.name && r.config == config) group.push_back(r);
      if (group.empty()) continue;
      BenchCell cell = Summarize(group);
      if (cell.num_failed > 0)
        summary_.notes.push_back(
            pr.sequence.name + " " + config + ": " + std::to_string(cell.num_failed) + " of " +
            std::to_string(cell.num_runs) +
            " runs without an ATE (fewer than 3 poses) left out of the medians");
      summary_.cells.push_back(cell);
      for (const BenchRun& r : runs_)
        if (r.sequence == pr.sequence.name && r.config == config)
          grouped_[{r.sequence, config}].push_back(&r);
    }
  }
}

// γ on the same frame set: the no-filter runs' ATE over each configuration's frames.
void BenchController::ComputeReferenceAte() {
  for (BenchCell& cell : summary_.cells) {
    if (cell.config == kNoFilterConfig || cell.median_run < 0) continue;
    const auto none_runs = grouped_.find({cell.sequence, kNoFilterConfig});
    if (none_runs == grouped_.end()) continue;
    const Prepared* pr = nullptr;
    for (const Prepared& candidate : prepared_)
      if (candidate.sequence.name == cell.sequence) pr = &candidate;
    if (!pr) continue;
    try {
      std::vector<std::vector<StampedPose>> none_trajectories;
      for (const BenchRun* r : none_runs->second)
        none_trajectories.push_back(ReadTumTrajectory(r->trajectory_path));
      const BenchRun& median = *grouped_[{cell.sequence, cell.config}][cell.median_run];
      SetReferenceAte(pr->groundtruth, none_trajectories, ReadTumTrajectory(median.trajectory_path),
                      &cell);
    } catch (const InputError& e) {  // --report-only after the run folders were removed
      summary_.notes.push_back(cell.sequence + " " + cell.config +
                               ": γ against the no-filter ATE over all its frames (" + e.what() +
                               ")");
    }
  }
}

// The trajectory pictures (top view + ATE over time, per configuration and compared) through
// scripts/bench_plots.py and a manifest of the median runs' pairs; the features picture.
void BenchController::DrawPictures() {
  // Where --out is now (renamed away mid-run: the folder the bench started with), for the
  // pictures the plotting script writes by path.
  const fs::path out_now = PinnedFolderNow(options_.out_dir);
  const fs::path work_dir(options_.work_dir);
  std::ostringstream manifest;
  manifest << "{\"sequences\": [";
  bool first_sequence = true;
  for (const Prepared& pr : prepared_) {
    SequencePictures pics;
    pics.sequence = pr.sequence.name;
    const std::string base = SafeName(pr.sequence.name);
    std::ostringstream series;
    bool first_series = true;
    for (const BenchCell& cell : summary_.cells) {
      if (cell.sequence != pr.sequence.name) continue;
      const BenchRun& run = *grouped_[{cell.sequence, cell.config}][cell.median_run];
      if (!std::isfinite(run.ate.rmse)) continue;
      const std::string pairs = (work_dir / base / (cell.config + "_median_pairs.txt")).string();
      try {
        fs::create_directories(work_dir / base);
        WriteFileAtomically(pairs, AtePairsText(ComputeAte(
                                       pr.groundtruth, ReadTumTrajectory(run.trajectory_path))));
      } catch (const InputError& e) {  // --report-only after the run folders were removed
        summary_.notes.push_back(cell.sequence + " " + cell.config +
                                 ": picture skipped: " + e.what());
        std::cerr << "dygslam bench: picture skipped: " << e.what() << "\n";
        continue;
      }
      const std::string png = base + "_" + cell.config + ".png";
      pics.config_pngs[cell.config] = png;
      series << (first_series ? "" : ", ") << "{\"config\": " << JsonString(cell.config)
             << ", \"label\": " << JsonString(ConfigLabel(cell.config))
             << ", \"pairs\": " << JsonString(pairs)
             << ", \"png\": " << JsonString((out_now / png).string()) << "}";
      first_series = false;
    }
    if (!first_series) pics.comparison_png = base + "_compare.png";
    manifest << (first_sequence ? "" : ", ") << "{\"sequence\": " << JsonString(pr.sequence.name)
             << ", \"compare_png\": " << JsonString((out_now / pics.comparison_png).string())
             << ", \"series\": [" << series.str() << "]}";
    first_sequence = false;
    DrawFeaturesPicture(pr, &pics);
    pictures_.push_back(pics);
  }
  manifest << "]}\n";
  const std::string manifest_path = (work_dir / "plots.json").string();
  WriteFileAtomically(manifest_path, manifest.str());
  const int code = RunProgram({"python3", options_.plots_script, "--manifest", manifest_path});
  if (code != 0) {
    const std::string why = code == 3 ? "python3-matplotlib is not installed"
                                      : "bench_plots.py exit code " + std::to_string(code);
    std::cerr << "dygslam bench: trajectory pictures skipped: " << why << "\n";
    summary_.notes.push_back("trajectory pictures skipped: " + why);
    for (SequencePictures& pics : pictures_) {
      pics.comparison_png.clear();
      pics.config_pngs.clear();
    }
  }
}

// The features picture of one frame (needs the detector model): skipped with a note when it
// cannot be drawn.
void BenchController::DrawFeaturesPicture(const Prepared& pr, SequencePictures* pics) {
  const std::string png = SafeName(pr.sequence.name) + "_features.png";
  const std::string path = (fs::path(options_.out_dir) / png).string();
  try {
    const RgbdDataset dataset = RgbdDataset::Open(pr.sequence.directory);
    size_t entry = options_.features_frame >= 0
                       ? static_cast<size_t>(options_.features_frame)
                       : pr.first + static_cast<size_t>(0.7 * (pr.last - pr.first));
    while (entry > pr.first && !dataset.FrameForRgbEntry(entry)) --entry;
    const FeatureFigure figure =
        DrawFeatureFigure(dataset, entry, SystemOptionsFromSettings(pr.settings));
    std::vector<uchar> encoded;
    if (!cv::imencode(".png", figure.image, encoded))
      throw InputError(path, 0, "cannot encode PNG");
    WriteFileAtomically(path, std::string(encoded.begin(), encoded.end()));
    pics->features_png = png;
    pics->features_caption = figure.caption;
  } catch (const std::exception& e) {  // InputError, InvalidOptions (no detector model)
    summary_.notes.push_back(pr.sequence.name + ": features picture skipped: " + e.what());
    std::cerr << "dygslam bench: features picture skipped: " << e.what() << "\n";
  }
}

// report.md, and the bench section of --update-benchmarks unless runs were stopped or left out
// (a partial report would lose their rows and misstate its run count: the file keeps the last
// complete one).
void BenchController::WriteReports() {
  BenchContext context;
  context.command_line = options_.command_line;
  context.date = UtcNow();
  context.runs = options_.runs;
  if (options_.report_only) {
    if (recorded_.count("command")) context.command_line = recorded_["command"];
    if (recorded_.count("date")) context.date = recorded_["date"];
    int max_run = -1;
    for (const BenchRun& r : runs_) max_run = std::max(max_run, r.run);
    context.runs = max_run + 1;
    summary_.notes.push_back("report rebuilt with --report-only from runs.csv");
  }
  context.machine = MachineDescription();
  context.load = load_text_;
  context.version = DYGSLAM_VERSION;
  context.data_dir = options_.data_dir;
  context.quick = options_.quick;
  context.deterministic = options_.deterministic;
  context.frames = !options_.frames.empty()
                       ? "rgb.txt entries " + options_.frames
                       : (options_.quick ? "at most 60 from the middle of each sequence" : "");
  context.configs = AllConfigs();
  for (const Prepared& pr : prepared_) {
    std::error_code ec;
    if (fs::is_regular_file(fs::path(pr.sequence.directory) / "detections.txt", ec))
      context.file_detection_sequences.push_back(pr.sequence.name);
  }
  for (const std::string& s : skipped_) summary_.notes.push_back("skipped " + s);
  context.notes = summary_.notes;
  WriteFileAtomically(summary_.report_path,
                      "# dygslam bench report\n\n" +
                          RenderBenchMarkdown(context, summary_.cells, pictures_, "") + "\n");
  const std::string& target = options_.update_benchmarks;
  if (!target.empty() && summary_.stopped_by != 0) {
    std::cerr << "dygslam bench: " << target << " not updated: the runs were stopped by signal "
              << summary_.stopped_by << " (the partial report is " << summary_.report_path << ")\n";
    summary_.exit_code = 128 + summary_.stopped_by;
  } else if (!target.empty() && summary_.runs_left_out > 0) {
    std::cerr << "dygslam bench: " << target << " not updated: " << summary_.runs_left_out << " of "
              << summary_.total_runs << " runs failed and were left out (the partial report is "
              << summary_.report_path << ")\n";
    summary_.exit_code = 1;
  } else if (!target.empty()) {
    const fs::path absolute = fs::absolute(target);
    std::string prefix = fs::relative(options_.out_dir, absolute.parent_path()).generic_string();
    prefix = (prefix.empty() || prefix == ".") ? "" : prefix + "/";
    WriteFileAtomically(
        absolute.string(),
        ReplaceBetweenMarkers(ReadWhole(absolute.string()),
                              RenderBenchMarkdown(context, summary_.cells, pictures_, prefix),
                              absolute.string()));
    summary_.benchmarks_updated = absolute.string();
  }
}

void RunBenchWorker(const BenchWorkerOptions& o) {
  // The baseline reads only the camera; its name is no filter configuration.
  RunConfiguration c = LoadRunConfiguration(
      {o.settings_path, o.settings_read,
       o.config == kBaselineConfig ? std::string("full") : BaseFilterConfiguration(o.config),
       o.deterministic});
  if (o.config != kBaselineConfig) ApplyAblationStep(o.config, &c.system);
  const RgbdDataset dataset = RgbdDataset::Open(o.dataset_dir);
  size_t first = 0, last = dataset.num_rgb_entries();
  if (!o.frames.empty()) std::tie(first, last) = ParseFrameRange(o.frames, last);
  const double t0 = SteadySeconds();
  const RunProgress report = [&](size_t done, size_t total) {
    if (o.quiet || (done % 10 != 0 && done != total)) return;
    std::fprintf(stderr, "\r%s frame %zu/%zu (%.1f fps)   ", o.progress_prefix.c_str(), done, total,
                 done / std::max(SteadySeconds() - t0, 1e-9));
    std::fflush(stderr);
  };
  const RunOutput output =
      o.config == kBaselineConfig
          ? RunOdometryOnSequence(dataset, c.settings.camera, c.settings.sensor.depth_map_factor,
                                  RgbdOdometryOptions(), first, last, report)
          : RunSystemOnSequence(dataset, c.system, first, last, report);
  WriteRunOutput(o.out_dir, output);
}

std::string BenchSummaryText(const BenchSummary& summary) {
  std::string text;
  char line[512];
  std::snprintf(line, sizeof(line), "%-24s %-20s %8s %8s %8s %9s %8s %7s\n", "sequence",
                "configuration", "rmse", "mean", "sd", "gamma", "ms/frame", "fps");
  text += line;
  for (const BenchCell& c : summary.cells) {
    double mu = std::nan("");
    for (const BenchCell& n : summary.cells)
      if (n.sequence == c.sequence && n.config == kNoFilterConfig) mu = n.ate.rmse;
    const double gamma = c.config == kNoFilterConfig ? std::nan("") : Improvement(c.ate.rmse, mu);
    char gamma_text[32] = "-";
    if (std::isfinite(gamma)) std::snprintf(gamma_text, sizeof(gamma_text), "%.2f%%", gamma);
    std::snprintf(line, sizeof(line), "%-24s %-20s %8.4f %8.4f %8.4f %9s %8.2f %7.1f\n",
                  c.sequence.c_str(), c.config.c_str(), c.ate.rmse, c.ate.mean, c.ate.sd,
                  gamma_text, c.stages.total_ms, c.fps);
    text += line;
  }
  if (!summary.benchmarks_updated.empty()) text += "updated " + summary.benchmarks_updated + "\n";
  text += "report: " + summary.report_path + "\nruns:   " + summary.runs_path + "\n";
  return text;
}

}  // namespace dygslam
