// `dygslam run` below the command line: one run of the SLAM over a range of a dataset's frames,
// in one of three modes that give the same outputs and the same summary:
//   kDirect             no DDS: this process feeds the System frame by frame (the library loop);
//                       the map is built by a KeyframeMapper thread
//   kPipeline           the DDS components on threads of this process
//   kPipelineProcesses  the DDS components, one process per component
// The run layer includes no DDS header: the pipeline modes run through a PipelineRunner the
// caller supplies (components/pipeline.h behind it).
//
//   RunControllerOptions options;  // filled from the command line
//   options.Check();               // InvalidOptions naming the field
//   RunController controller(options, dataset, ground_truth, pipeline_runner);
//   const int exit_code = controller.Run();  // summary on stdout, OUT/eval.json
#pragma once

#include <cstddef>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/base/timestamp.h"
#include "core/base/types.h"
#include "core/io/dataset.h"
#include "core/system/system.h"
#include "mapping/octomap_builder.h"
#include "run/run_outputs.h"
#include "run/run_summary.h"

namespace dygslam {

class KeyframeMapper;      // mapping/keyframe_mapper.h
struct DatasetRunSummary;  // run/dataset_runner.h

enum class RunMode { kDirect, kPipeline, kPipelineProcesses };

struct RunControllerOptions {
  std::string dataset_dir;
  std::string settings_path;  // the settings file the options were read from
  std::string filter;         // the --filter name, for the summary
  SystemOptions system;
  OctoMapOptions octomap;
  size_t first = 0, last = 0;  // rgb.txt entries [first, last)
  std::filesystem::path out;   // the output folder (exists)
  RunMode mode = RunMode::kDirect;
  bool map = true;          // build map.bt
  bool progress = true;     // a progress line on stderr
  double rate = 0;          // frames arrive as from a camera at this many times real time (0: off)
  double loop_minutes = 0;  // pipeline modes: the player replays the frames for this long
  // Boxes from a file instead of the detector (direct mode only), by frame stamp.
  std::map<Timestamp, std::vector<Detection>> detections;
  bool use_detection_file = false;
  std::string save_map;      // the SLAM map file written at the end ("" none)
  std::string load_octomap;  // the OctoMap the map continues ("" none)
  // Pipeline modes: the DDS domain (-1: the environment's or 0), partition ("" unique per run)
  // and security folder ("" off).
  int domain_id = -1;
  std::string partition;
  std::string security_dir;

  // Throws InvalidOptions naming the field.
  void Check() const;
};

// What a pipeline mode reports when it ends (components/pipeline.h StopReport and exit code).
struct PipelineRunResult {
  int exit_code = 0;         // 0, or 1 when a component failed
  bool interrupted = false;  // stopped by SIGINT / SIGTERM
  size_t ignored_samples = 0;
  // What the pipeline says of them, for the summary's `dds:` line ("" when none).
  std::string ignored_samples_note;
  std::vector<std::string> components_cut_short;
};
// Runs the DDS pipeline for `options` (its outputs in options.out); supplied by the caller.
using PipelineRunner = std::function<PipelineRunResult(const RunControllerOptions& options)>;

class RunController {
 public:
  // `dataset`: opened over options.dataset_dir; `ground_truth`: its ground truth (empty: none or
  // unreadable, said before). The outputs' versions are taken here: construct right before Run().
  // Without `pipeline` (a build without the DDS components) the default mode runs direct, said
  // on stderr, and kPipelineProcesses is an error.
  RunController(RunControllerOptions options, const RgbdDataset& dataset,
                std::vector<StampedPose> ground_truth, PipelineRunner pipeline = {});

  // Warns when frames of the range have no depth partner, runs, writes the outputs (each
  // atomically; one that fails does not stop the others), prints the summary on stdout and writes
  // OUT/eval.json. Returns the exit code: 0, 1 (a failure: an output not written, a component
  // failed, tracking failed), kExitIncompleteRun (fewer frames than requested without a stop the
  // user gave). Rethrows an error that stopped the direct loop (after writing the outputs of the
  // frames before it).
  int Run();

  const RunSummary& summary() const { return summary_; }
  // Frames of the range with a depth partner, and rgb.txt entries of the range without one.
  size_t requested() const { return requested_; }
  size_t without_depth_partner() const { return without_depth_partner_; }

 private:
  struct Outcome;
  Outcome RunDirect();
  // The direct loop's map stage (nullptr without the map), fed by `system`'s keyframes.
  std::unique_ptr<KeyframeMapper> MakeMapper(System* system) const;
  void WriteDirectRealtimeReport(const DatasetRunSummary& summary);
  // The direct loop's outputs (each atomically; a failure is recorded, the others go on).
  // `record`: the rows and online poses of the frames processed; the refined trajectories are
  // taken from `system`.
  void WriteDirectOutputs(const System& system, KeyframeMapper* mapper, RunRecord record);
  // A --load-map run that added no keyframe: map.bt from the loaded map's points.
  void WriteLoadedMapOctoMap();
  Outcome RunPipeline();
  RunSummary BaseSummary() const;
  void Evaluate(const std::vector<StampedPose>& trajectory);
  // The summary of a run that ended (no output written).
  void Summarize(const Outcome& outcome, size_t in_trajectory, double elapsed);
  // This run's trajectory file `name` as written (empty when not written); one that does not read
  // back is recorded as a failed output.
  std::vector<StampedPose> ReadBackTrajectory(const std::string& name);
  int Finish(const Outcome& outcome, double elapsed);
  // The exit code of a finished run, with its reason on stderr.
  int ReportExit(const Outcome& outcome, size_t in_trajectory, bool incomplete,
                 bool tracking_failure, double elapsed) const;

  RunControllerOptions options_;
  const RgbdDataset& dataset_;
  std::vector<StampedPose> ground_truth_;
  PipelineRunner pipeline_;
  RunOutputs outputs_;
  size_t requested_ = 0, without_depth_partner_ = 0;
  RunSummary summary_;
};

// What the command line asks of the mode: --direct, --processes, a --detections file (runs
// direct), --security (secures the DDS pipeline), --loop-minutes.
struct RunModeRequest {
  bool direct = false;
  bool processes = false;
  bool detections = false;
  bool security = false;
  bool loop = false;
};
// The mode asked for; throws UsageError when the request's parts exclude each other.
RunMode ChooseRunMode(const RunModeRequest& request);

// The mode's name in the summary ("direct (no DDS)", "DDS pipeline, one process", ...).
const char* ToString(RunMode mode);

}  // namespace dygslam
