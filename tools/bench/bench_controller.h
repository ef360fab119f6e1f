// The benchmark of `dygslam bench`: every filter configuration and the RGB-D odometry baseline on
// every sequence of a data folder, N runs each (each run a worker process, so that its peak
// memory is its own), scored against the ground truth, medians in the layout of the paper's
// tables, pictures, report.md / runs.csv, and optionally the bench section of BENCHMARKS.md.
//
//   BenchControllerOptions options = ...;   // folders prepared and checked by the command
//   BenchController bench(options);          // options.Check()
//   if (std::string why = bench.FindUsageProblem(); !why.empty()) ...  // before any run
//   const BenchSummary& summary = bench.Run();
//
// SIGINT / SIGTERM / SIGHUP (ScopedStopSignals) stop the runs between two (the current one is
// passed the signal and left out): the report of the runs done so far is written, and the bench
// section of --update-benchmarks is left as it was.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "core/config/settings.h"
#include "core/io/dataset.h"
#include "core/system/system.h"
#include "tools/bench/bench_report.h"
#include "tools/bench/bench_sequences.h"

namespace dygslam {

struct BenchControllerOptions {
  std::string data_dir;  // a sequence folder or a folder of them
  int runs = 5;          // per sequence and configuration
  bool quick = false;    // at most 60 frames from the middle of each sequence (unless frames)
  std::vector<std::string> configs = {"none", "boxes", "geometry", "full"};
  bool baseline = true;           // also the cv::rgbd::RgbdICPOdometry baseline
  std::string frames;             // "FIRST:LAST" rgb.txt entries of every sequence, "" = all
  std::string out_dir;            // report.md, runs.csv, pictures (made and checked by the command)
  std::string work_dir;           // one folder per run (made and checked by the command)
  std::string update_benchmarks;  // a Markdown file whose bench section is replaced, "" = none
  std::string settings_path;      // one settings file for every sequence, "" = per sequence
  std::string config_dir;         // the settings presets (config/)
  std::string plots_script;       // scripts/bench_plots.py
  std::string worker_executable;  // the dygslam executable run as `bench --worker`
  SettingsReadOptions settings_read;
  bool deterministic = false;
  int64_t features_frame = -1;  // rgb.txt entry of the features picture, -1 = 70 % into the range
  bool pictures = true;
  bool report_only = false;  // no runs: report and pictures from out_dir/runs.csv
  bool quiet = false;
  std::string command_line;  // as typed, for the report
  // Said about each sequence before any run (listing problems, implausible depth, a ground truth
  // that does not cover the frames).
  std::function<void(const RgbdDataset&, size_t first, size_t last, const SystemOptions&,
                     const std::vector<StampedPose>& groundtruth)>
      warn_about_dataset;

  // Throws InvalidOptions naming the option ("--runs", "--configs", ...).
  void Check() const;
};

struct BenchSummary {
  std::vector<BenchCell> cells;  // medians per sequence and configuration
  std::string report_path, runs_path;
  std::string benchmarks_updated;  // the file whose bench section was replaced, "" = none
  int total_runs = 0;              // runs planned
  int runs_left_out = 0;           // workers that failed or left unreadable outputs
  int stopped_by = 0;              // the stop signal that ended the runs early, 0 = none
  std::vector<std::string> notes;  // what the report says besides its tables
  int exit_code = 0;
};

class BenchController {
 public:
  explicit BenchController(BenchControllerOptions options);

  // Why the bench may not start, "" when it may (a usage error for the command): an earlier
  // bench's outputs are replaced, never a user's files of the same names; --update-benchmarks is
  // a Markdown file with the bench markers, outside every dataset, and none of the bench's
  // inputs or outputs; the sequences are found and --features-frame lies in each. Reads every
  // sequence's settings, dataset and ground truth (InputError naming the file).
  std::string FindUsageProblem();

  // Runs, scores, reports (FindUsageProblem first, when it was not called).
  const BenchSummary& Run();

 private:
  struct Prepared {
    BenchSequence sequence;
    Settings settings;
    size_t first = 0, last = 0;
    std::vector<StampedPose> groundtruth;
    size_t num_entries = 0;
  };
  std::string FindForeignOutput() const;
  std::string CheckUpdateFile() const;
  std::string Prepare();
  std::vector<std::string> AllConfigs() const;
  void RunAll();
  void RunOne(const Prepared& prepared, int run, const std::string& config, int* done);
  void ReadEarlierRuns();
  void WriteRunsCsv();
  void ComputeMedians();
  void ComputeReferenceAte();
  void DrawPictures();
  void DrawFeaturesPicture(const Prepared& prepared, SequencePictures* pictures);
  void WriteReports();

  BenchControllerOptions options_;
  bool checked_ = false;
  std::vector<std::string> skipped_;
  std::vector<Prepared> prepared_;
  std::vector<BenchRun> runs_;
  std::map<std::string, std::string> recorded_;  // the earlier bench's context (--report-only)
  std::string load_start_, load_text_;
  std::vector<double> load_samples_;
  double started_ = 0;  // steady clock, s
  std::map<std::pair<std::string, std::string>, std::vector<const BenchRun*>> grouped_;
  std::vector<SequencePictures> pictures_;
  BenchSummary summary_;
};

// One run of a bench in this process (`dygslam bench --worker CONFIG`): a filter configuration
// or the baseline on rgb.txt entries `frames` of the sequence, its run folder written to out_dir.
struct BenchWorkerOptions {
  std::string config;  // a filter configuration or kBaselineConfig
  std::string dataset_dir, settings_path, out_dir;
  std::string frames;  // "FIRST:LAST", "" = all
  SettingsReadOptions settings_read;
  bool deterministic = false;
  bool quiet = false;
  std::string progress_prefix;
};
void RunBenchWorker(const BenchWorkerOptions& options);

// The bench's stdout summary: one line per cell (rmse, mean, sd, γ, ms/frame, fps) and where the
// report and runs.csv are.
std::string BenchSummaryText(const BenchSummary& summary);

}  // namespace dygslam
