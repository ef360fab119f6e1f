// Measurements, medians and the Markdown report of `dygslam bench`.
//
// One BenchRun per (sequence, configuration, run). Summarize() takes the runs of one sequence and
// configuration and gives the median of every figure over the runs (the paper's protocol: N runs,
// median). RenderBenchMarkdown() lays the medians out like the paper: accuracy like Tables 1-2
// (ATE RMSE / mean / S.D. and the improvement gamma = (1 - eta / mu) x 100 % over the no-filter
// configuration) and per-stage times like Table 3, plus frames/s and peak memory.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "core/eval/trajectory_eval.h"

namespace dygslam {

// Configuration names: the four filter modes (core/system FilterMode names) and the baseline.
inline constexpr const char* kNoFilterConfig = "none";
inline constexpr const char* kBaselineConfig = "rgbd_icp_odometry";
// Human-readable name of a configuration ("full" -> "full method (DYG-SLAM)").
std::string ConfigLabel(const std::string& config);

// Mean per-frame times of one run, milliseconds (core/system StageTimes).
struct StageMeans {
  double orb_ms = 0;
  double detection_ms = 0;       // detector wall time; runs concurrently with ORB extraction
  double detection_wait_ms = 0;  // time tracking waited for the detector after extraction
  double matching_ms = 0;
  double probability_ms = 0;
  double tracking_ms = 0;
  double local_mapping_ms = 0;  // only in deterministic mode (synchronous local mapping)
  double total_ms = 0;          // wall time per frame (SLAM: FeedRgbdFrame; baseline: odometry)
  double median_total_ms = 0;   // median over the frames of total_ms (the others are means)
};

struct BenchRun {
  std::string sequence;
  std::string config;
  int run = 0;
  std::string trajectory_path;  // the TUM trajectory the ATE was computed on
  int frames = 0;               // frames processed
  int poses = 0;                // poses in the trajectory
  int lost = 0;                 // SLAM: frames in state lost; baseline: rejected steps
  int ate_pairs = 0;
  ErrorStatistics ate;  // metres
  StageMeans stages;
  double loop_seconds = 0;  // wall time of the frame loop (image loading included)
  double fps = 0;           // frames / loop_seconds
  double peak_rss_mib = 0;  // peak resident memory of the run's process
};

// Medians over the runs of one sequence and configuration.
struct BenchCell {
  std::string sequence;
  std::string config;
  int num_runs = 0;
  int num_failed = 0;   // runs without an ATE (fewer than 3 poses associated)
  ErrorStatistics ate;  // each field: median over the runs with an ATE
  double rmse_min = 0, rmse_max = 0;
  double ate_pairs = 0, frames = 0, poses = 0, lost = 0;
  StageMeans stages;
  double fps = 0;
  double peak_rss_mib = 0;
  // Index (into the runs given to Summarize) of the run whose RMSE is the median (lower median
  // for an even count): the run drawn in the pictures.
  int median_run = -1;
  // γ's μ on the same frame set: the no-filter ATE over only the frames this
  // configuration has a pose for (median over the no-filter runs; the frame set of this
  // configuration's median run). Unset: γ uses the no-filter cell's ATE as it is.
  bool has_reference_ate = false;
  ErrorStatistics reference_ate;
};

// Median of the finite values (mean of the two middle ones for an even count); NaN if none.
double Median(std::vector<double> values);
// gamma = (1 - eta / mu) x 100 %; NaN when mu <= 0 or either is not finite.
double Improvement(double eta, double mu);
// Throws std::invalid_argument when `runs` is empty or mixes sequences / configurations.
BenchCell Summarize(const std::vector<BenchRun>& runs);
// The ATE of `estimate` over only the stamps that `frame_set` has a pose for (same stamp within
// 1 microsecond). Fewer than 3 associated pairs: every field NaN.
ErrorStatistics AteOnFrameSet(const std::vector<StampedPose>& groundtruth,
                              const std::vector<StampedPose>& estimate,
                              const std::vector<StampedPose>& frame_set);
// Sets cell.reference_ate to the medians of AteOnFrameSet over the no-filter trajectories, with
// the frame set of the cell's median-run trajectory.
void SetReferenceAte(const std::vector<StampedPose>& groundtruth,
                     const std::vector<std::vector<StampedPose>>& no_filter_trajectories,
                     const std::vector<StampedPose>& frame_set, BenchCell* cell);

// Pictures of one sequence, paths relative to the report's directory ("" = not drawn).
struct SequencePictures {
  std::string sequence;
  std::string comparison_png;                      // all configurations: top view + ATE over time
  std::map<std::string, std::string> config_pngs;  // per configuration: top view + ATE over time
  std::string features_png;                        // static / dynamic features on one frame
  std::string features_caption;
};

struct BenchContext {
  std::string command_line;
  std::string date;     // UTC
  std::string machine;  // CPU model, cores, memory
  std::string load;     // load averages during the benchmark
  std::string version;
  std::string data_dir;
  int runs = 0;
  bool quick = false;
  bool deterministic = false;
  std::string frames;  // which frames, e.g. "rgb.txt entries 100:200"; "" = all
  std::vector<std::string> configs;
  std::vector<std::string> notes;  // extra lines (skipped sequences, failures)
  // Sequences whose boxes came from their detections.txt (generated data) instead of the
  // detector: their box-using rows are marked in the report.
  std::vector<std::string> file_detection_sequences;
};

// The report. `image_prefix` is prepended to every picture path (e.g. "docs/benchmarks/" when the
// text goes into BENCHMARKS.md at the repository root). Cells are grouped by sequence in the order
// given; configurations in the order of context.configs, the baseline last.
std::string RenderBenchMarkdown(const BenchContext& context, const std::vector<BenchCell>& cells,
                                const std::vector<SequencePictures>& pictures,
                                const std::string& image_prefix = "");

// Every run as CSV (one header line, one line per run), the machine-readable record of a bench.
std::string BenchRunsCsv(const std::vector<BenchRun>& runs);
// Reads BenchRunsCsv() output. Throws InputError naming the file, line and column.
std::vector<BenchRun> ReadBenchRunsCsv(const std::string& path);

inline constexpr const char* kBenchBeginMarker = "<!-- bench:begin -->";
inline constexpr const char* kBenchEndMarker = "<!-- bench:end -->";
// `text` with everything between the two markers replaced by `content` (markers kept, each on
// its own line). Throws InputError naming `file_name` when a marker is missing, repeated or the
// end marker precedes the begin marker.
std::string ReplaceBetweenMarkers(const std::string& text, const std::string& content,
                                  const std::string& file_name);

}  // namespace dygslam
