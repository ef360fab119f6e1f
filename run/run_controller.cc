#include "run/run_controller.h"

#include <octomap/OcTree.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <memory>
#include <optional>
#include <set>
#include <stdexcept>

#include "core/base/echo.h"
#include "core/base/error.h"
#include "core/base/standard_output.h"
#include "core/base/stop_signal.h"
#include "core/eval/trajectory_eval.h"
#include "core/io/file_util.h"
#include "core/io/trajectory_io.h"
#include "core/slam/loop_closing/loop_closing.h"
#include "core/slam/map/map_file.h"
#include "mapping/keyframe_mapper.h"
#include "run/dataset_runner.h"
#include "run/realtime_report.h"

namespace dygslam {
namespace fs = std::filesystem;

namespace {

// --rate above 0: the slowest replay that is still a replay (0.01x = a 30 Hz frame every 3.3 s).
constexpr double kMinRate = 0.01;

// The frames a camera-paced run (--rate) dropped by design: those the pipeline could not take in
// time (realtime.txt). Missing frames beyond them were cut short.
// A stall (no result for seconds while frames arrived: a component paused) explains none.
size_t DroppedByRate(const RunSummary& summary) {
  return summary.realtime && !summary.realtime->Stalled() ? summary.realtime->dropped() : 0;
}

double MedianOf(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// The statistics of the System's threads after a direct run: local mapping, the map, loops.
void PrintSystemStatistics(const System& system) {
  const LocalMappingStats lm = system.LocalMappingStatistics();
  std::printf(
      "local mapping: %d keyframes, median %.1f ms per keyframe, %d points triangulated, "
      "%d keyframes culled\n",
      lm.keyframes_processed, MedianOf(lm.per_keyframe_ms), lm.points_triangulated,
      lm.keyframes_culled);
  std::printf("local BA: median %.0f keyframes optimised, %.0f observations\n",
              MedianOf(std::vector<double>(lm.ba_keyframes.begin(), lm.ba_keyframes.end())),
              MedianOf(std::vector<double>(lm.ba_observations.begin(), lm.ba_observations.end())));
  std::printf(
      "local mapping schedule: local BA solve median %.1f ms, in tracking's thread median "
      "%.1f ms per keyframe; %d local BAs late (tracking waited %.0f ms in all), %d landed "
      "early (next keyframe)\n",
      MedianOf(lm.solve_ms), MedianOf(lm.insert_ms), lm.late_bundle_adjustments, lm.late_wait_ms,
      lm.early_landings);
  const MapStatistics sizes = system.MapSizes();
  std::printf("map: %zu keyframes (%zu culled), %zu map points\n", sizes.keyframes,
              sizes.culled_keyframes, sizes.map_points);
  const LoopClosingStats lc = system.LoopClosingStatistics();
  std::printf(
      "loop closing: %d loops closed (%d consistent candidates, %d rejected), %d points fused, "
      "%d global BA (%d discarded), %d keyframes checked\n",
      lc.loops_closed, lc.candidates_detected, lc.loops_rejected, lc.points_fused,
      lc.global_ba_runs, lc.global_ba_discarded, lc.keyframes_checked);
  std::printf(
      "loop checks: detection %.0f ms, geometry %.0f ms (%.0f ms of it holding the map lock), "
      "%d loops dropped (map changed), %d loops fused only (no pose graph, no global BA)\n",
      lc.detect_ms_total, lc.check_ms_total, lc.check_locked_ms_total, lc.loops_dropped,
      lc.pose_graph_skipped);
  if (const std::string line = LoopRejectionSummary(lc); !line.empty())
    std::printf("%s\n", line.c_str());
  for (const auto& [frame, loop_frame] : lc.loop_frames)
    std::printf("loop: frame %lld closed with frame %lld\n", static_cast<long long>(frame),
                static_cast<long long>(loop_frame));
}

// "poses: N of M frames (P %): ok .., fallback .., ..": frames with a pose by how it was
// obtained; lost and not_initialized frames have none.
void PrintPoseCounts(const std::map<std::string, size_t>& states, size_t processed) {
  auto count = [&](TrackingState state) {
    auto it = states.find(ToString(state));
    return it == states.end() ? size_t{0} : it->second;
  };
  const size_t with_pose = count(TrackingState::kOk) + count(TrackingState::kFallback) +
                           count(TrackingState::kRelocalized);
  std::printf(
      "poses: %zu of %zu frames (%.1f %%): ok %zu, fallback %zu, relocalized %zu, lost %zu, "
      "not initialised %zu\n",
      with_pose, processed, 100.0 * with_pose / std::max<size_t>(processed, 1),
      count(TrackingState::kOk), count(TrackingState::kFallback),
      count(TrackingState::kRelocalized), count(TrackingState::kLost),
      count(TrackingState::kNotInitialized));
}

// "integrity: ..." of a run (`loop_minutes`: the replay's length, 0 for none).
void PrintIntegrity(const RunSummary& summary, double loop_minutes) {
  if (loop_minutes > 0) {
    std::printf(
        "integrity: %zu frames processed (the %zu requested frames replayed for %g min)%s\n",
        summary.processed, summary.requested, loop_minutes,
        summary.Reason() == Shortfall::kNone
            ? ""
            : (std::string(": ") + ToString(summary.Reason())).c_str());
  } else if (summary.Reason() == Shortfall::kComponentCutShort) {
    std::printf("integrity: %zu of %zu requested frames processed: %s\n", summary.processed,
                summary.requested, ToString(summary.Reason()));
  } else if (summary.Reason() == Shortfall::kNone) {
    // Entries without a depth partner are not requested frames; said here as well as before the
    // run, so that a depth.txt cut short cannot read as a complete run.
    const std::string left_out =
        summary.without_depth_partner == 0
            ? ""
            : "; " + std::to_string(summary.without_depth_partner) +
                  " rgb.txt entries of the range left out: no depth image to pair with";
    std::printf("integrity: %zu of %zu requested frames processed (complete%s)\n",
                summary.processed, summary.requested, left_out.c_str());
  } else {
    std::printf(
        "integrity: %zu of %zu requested frames processed, %zu missing, %zu not this run's: "
        "%s\n",
        summary.processed, summary.requested, summary.Missing(), summary.foreign_frames,
        ToString(summary.Reason()));
  }
}

// "outputs: DIR/{a,b,..}" of the files this run wrote; a file an earlier run left (not replaced)
// is named apart.
void PrintOutputs(const RunOutputs& outputs) {
  std::string written, stale;
  for (const std::string& name : RunOutputNames()) {
    if (outputs.Fresh(name)) {
      written += (written.empty() ? "" : ",") + std::string(name);
    } else if (outputs.Stale(name)) {
      stale += (stale.empty() ? "" : ", ") + std::string(name);
    }
  }
  std::printf("outputs: %s/{%s}\n", fs::path(outputs.PathOf("")).parent_path().string().c_str(),
              written.c_str());
  if (!stale.empty())
    std::printf("outputs left from an earlier run, not replaced by this one: %s\n", stale.c_str());
}

}  // namespace

const char* ToString(RunMode mode) {
  switch (mode) {
    case RunMode::kDirect:
      return "direct (no DDS)";
    case RunMode::kPipeline:
      return "DDS pipeline, one process";
    case RunMode::kPipelineProcesses:
      return "DDS pipeline, one process per component";
  }
  return "?";
}

RunMode ChooseRunMode(const RunModeRequest& r) {
  if (r.processes && r.direct) throw UsageError("--processes and --direct exclude each other");
  if (r.security && (r.direct || r.detections))
    throw UsageError("--security secures the DDS pipeline; --direct and --detections use no DDS");
  if (r.detections && r.processes) throw UsageError("--detections works with --direct only");
  if (r.loop && (r.direct || r.detections))
    throw UsageError(std::string("--loop-minutes works with the DDS modes only (") +
                     (r.direct ? "not --direct)" : "--detections runs direct)"));
  if (r.direct || r.detections) return RunMode::kDirect;
  return r.processes ? RunMode::kPipelineProcesses : RunMode::kPipeline;
}

void RunControllerOptions::Check() const {
  if (dataset_dir.empty()) throw InvalidOptions("RunControllerOptions.dataset_dir is empty");
  if (out.empty()) throw InvalidOptions("RunControllerOptions.out is empty");
  if (last < first)
    throw InvalidOptions("RunControllerOptions.last (" + std::to_string(last) +
                         ") is before first (" + std::to_string(first) + ")");
  if (!(rate == 0 || (rate >= kMinRate && rate <= 1000)))
    throw InvalidOptions("RunControllerOptions.rate must be 0 or in 0.01..1000");
  if (!(loop_minutes >= 0)) throw InvalidOptions("RunControllerOptions.loop_minutes < 0");
  if (mode == RunMode::kDirect && loop_minutes > 0)
    throw InvalidOptions("RunControllerOptions.loop_minutes needs a pipeline mode");
  if (use_detection_file && mode != RunMode::kDirect)
    throw InvalidOptions("RunControllerOptions.detections need the direct mode");
  if (!load_octomap.empty() && !map)
    throw InvalidOptions("RunControllerOptions.load_octomap needs the map");
}

// What a mode delivered, before the summary.
struct RunController::Outcome {
  size_t processed = 0;
  size_t lost = 0;
  std::map<std::string, size_t> states;  // frames per tracking state (frames.csv `state`)
  bool interrupted = false;
  int exit_code = 0;
  size_t ignored_samples = 0;  // DDS: samples of writers outside this run (components/protocol.h)
  std::string ignored_samples_note;               // what the pipeline says of them ("" when none)
  std::vector<std::string> components_cut_short;  // --processes: ended before the run did
  std::vector<Timestamp> stamps;  // DDS: the stamps of the frames processed (frames.csv)
};

RunController::RunController(RunControllerOptions options, const RgbdDataset& dataset,
                             std::vector<StampedPose> ground_truth, PipelineRunner pipeline)
    : options_(std::move(options)),
      dataset_(dataset),
      ground_truth_(std::move(ground_truth)),
      pipeline_(std::move(pipeline)),
      outputs_(options_.out, RunOutputNames()) {
  options_.Check();
  // No runner: a build without the DDS components runs the library loop.
  if (options_.mode == RunMode::kPipelineProcesses && !pipeline_)
    throw InvalidOptions(
        "--processes: this build has no DDS components (configure with -DDYGSLAM_BUILD_DDS=ON)");
  if (options_.mode == RunMode::kPipeline && !pipeline_) {
    std::fprintf(stderr,
                 "[run] this build has no DDS components: running the direct library loop "
                 "(--direct)\n");
    options_.mode = RunMode::kDirect;
  }
  for (size_t k = options_.first; k < options_.last; ++k) {
    if (!dataset_.FrameForRgbEntry(k)) ++without_depth_partner_;
  }
  requested_ = options_.last - options_.first - without_depth_partner_;
  if (!options_.save_map.empty()) outputs_.AddFile(options_.save_map);
}

RunSummary RunController::BaseSummary() const {
  RunSummary r;
  r.mode = ToString(options_.mode);
  r.filter = options_.filter;
  r.deterministic = options_.system.deterministic;
  r.first = options_.first;
  r.last = options_.last;
  r.requested = requested_;
  r.without_depth_partner = without_depth_partner_;
  return r;
}

void RunController::WriteDirectOutputs(const System& system, KeyframeMapper* mapper,
                                       RunRecord record) {
  const RunControllerOptions& s = options_;
  RecreateOutputDirIfRemoved("run", "out", s.out);
  RunRecord refined = RunRecordOfSystem(system);
  record.trajectory = std::move(refined.trajectory);
  record.keyframes = std::move(refined.keyframes);
  WriteRunRecord(outputs_, record);
  RunOutputs& outputs = outputs_;
  // With --save-map, map.ot too (the OctoMap with probabilities, what --load-octomap continues).
  if (mapper) {
    outputs.Write("map.bt", [&] {  // a failure before the files (the mapper's) is map.bt's
      WriteMapperBinary(outputs, *mapper, /*with_full_map=*/!s.save_map.empty());
    });
  }
}

std::unique_ptr<KeyframeMapper> RunController::MakeMapper(System* system) const {
  const RunControllerOptions& s = options_;
  if (!s.map) return nullptr;
  auto mapper = std::make_unique<KeyframeMapper>(s.system.camera, s.octomap);
  if (!s.load_octomap.empty()) {
    const auto base = ReadOctoMap(s.load_octomap);
    mapper->WithBuilder([&](OctoMapBuilder& b) { b.SetBaseMap(*base, s.load_octomap); });
  }
  KeyframeMapper* m = mapper.get();
  system->SetKeyframeCallback([m](const KeyframeData& k) { m->Submit(k); });
  return mapper;
}

void RunController::WriteDirectRealtimeReport(const DatasetRunSummary& summary) {
  const RunControllerOptions& s = options_;
  const double fps = s.system.sensor.fps > 0 ? s.system.sensor.fps : 30.0;
  const double late_after_ms = kLateFramePeriods * 1000.0 / (fps * s.rate);
  outputs_.Write(kRealtimeReportFile, [&] {
    WriteRealtimeReport(outputs_.PathOf(kRealtimeReportFile),
                        MakeRealtimeReport(s.rate, summary.processed + summary.dropped,
                                           summary.latencies, late_after_ms));
  });
}

RunController::Outcome RunController::RunDirect() {
  const RunControllerOptions& s = options_;
  RunOutputs& outputs = outputs_;
  Outcome outcome;
  System system(s.system);
  std::unique_ptr<KeyframeMapper> mapper = MakeMapper(&system);
  // SIGINT / SIGTERM -> the stop flag the loop polls (shared with dygslam main's early scope).
  const StopFlag stop(StopFlag::Signals::kStop);
  DatasetRunOptions run;
  run.first_entry = s.first;
  run.last_entry = s.last;
  run.image_width = s.system.camera.width;
  run.image_height = s.system.camera.height;
  if (s.use_detection_file) run.detections = &s.detections;
  run.stop = [&stop] { return stop.requested(); };
  run.rate = s.rate;
  RunRecord record;
  record.rows.emplace();
  record.online.emplace();  // the pose known when each frame was tracked
  const auto t0 = std::chrono::steady_clock::now();
  const size_t total = s.last - s.first;
  size_t done = 0, lost = 0;  // for the progress line
  // A bad input found mid-run (an image that does not decode) ends the loop, but what the frames
  // before it gave is written below like on a stop signal; then the error is reported (exit 1).
  std::exception_ptr failure;
  DatasetRunSummary summary;
  try {
    summary = RunDatasetFrames(dataset_, system, run, [&](size_t k, const FrameResult& r) {
      ++done;
      if (r.state == TrackingState::kLost) ++lost;
      if (r.world_from_cam) record.online->push_back({r.stamp, *r.world_from_cam});
      ++outcome.states[ToString(r.state)];
      record.rows->push_back(FrameRowFromResult(r));
      if (s.progress && (done % 10 == 0 || k + 1 == s.last)) {
        const double elapsed =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        std::fprintf(stderr, "\r[run] frame %zu/%zu  %.1f fps  state=%s  lost=%zu   ",
                     k + 1 - s.first, total, done / std::max(elapsed, 1e-9), ToString(r.state),
                     lost);
        std::fflush(stderr);
      }
    });
  } catch (const std::exception&) {
    failure = std::current_exception();
    summary.processed = done;
    summary.lost = lost;
  }
  outcome.processed = summary.processed;
  outcome.lost = summary.lost;
  if (s.rate > 0) WriteDirectRealtimeReport(summary);
  if (s.progress) std::fprintf(stderr, "\n");
  outcome.interrupted = summary.interrupted || stop.requested();
  if (outcome.interrupted) std::fprintf(stderr, "[run] interrupted: flushing outputs\n");
  system.Shutdown();
  // Every output is written even when one of them fails (a --save-map onto a full disk): the
  // failures are reported at the end (exit 1).
  if (!s.save_map.empty()) {
    outputs.Write(s.save_map, [&] {
      std::printf("map file: saved %s (%s)\n", s.save_map.c_str(),
                  DescribeMapFile(system.SaveMap(s.save_map)).c_str());
    });
  }
  PrintSystemStatistics(system);
  WriteDirectOutputs(system, mapper.get(), std::move(record));
  if (failure) {
    std::fprintf(stderr, "%s", outputs.FailureReport("run").c_str());
    std::fprintf(stderr,
                 "[run] stopped by an error after %zu frames: the outputs of those frames are "
                 "written to %s (trajectory.txt, keyframes.txt, frames.csv%s)\n",
                 outcome.processed, s.out.string().c_str(), mapper ? ", map.bt" : "");
    std::rethrow_exception(failure);
  }
  return outcome;
}

RunController::Outcome RunController::RunPipeline() {
  // Nothing in DIR is deleted up front: the components replace each file atomically when theirs
  // is complete, and a file an earlier run left is told apart by its version (RunOutputs).
  const PipelineRunResult result = pipeline_(options_);
  Outcome outcome;
  outcome.exit_code = result.exit_code;
  outcome.interrupted = result.interrupted;
  outcome.ignored_samples = result.ignored_samples;
  outcome.ignored_samples_note = result.ignored_samples_note;
  outcome.components_cut_short = result.components_cut_short;
  if (outputs_.Fresh("frames.csv")) {
    for (const FrameRow& row : ReadFramesCsv(outputs_.PathOf("frames.csv"))) {
      ++outcome.processed;
      if (row.state == TrackingState::kLost) ++outcome.lost;
      ++outcome.states[ToString(row.state)];
      outcome.stamps.push_back(row.stamp);
    }
  }
  return outcome;
}

int RunController::Run() {
  if (without_depth_partner_ > 0) {
    // Said before the run, not only counted in the summary: a depth.txt cut short or with a gap
    // leaves frames out without any other sign.
    std::fprintf(stderr,
                 "dygslam run: warning: %zu of the %zu rgb.txt entries %zu to %zu have no depth "
                 "image to pair with (depth.txt / associations): they are left out, %zu frames "
                 "requested\n",
                 without_depth_partner_, options_.last - options_.first, options_.first,
                 options_.last, requested_);
  }
  Outcome outcome;
  const auto t0 = std::chrono::steady_clock::now();
  if (options_.mode == RunMode::kDirect) {
    try {
      outcome = RunDirect();
    } catch (const std::exception& e) {
      // Stopped by an error (a corrupt image mid-run): the outputs of the frames before it are
      // written; eval.json says so, so that an earlier run's stays no longer beside them.
      summary_ = BaseSummary();
      if (outputs_.Fresh("frames.csv"))
        summary_.processed = ReadDataLines(outputs_.PathOf("frames.csv")).size() - 1;
      summary_.error = e.what();
      summary_.ate_note = "not evaluated: the run stopped on an error";
      summary_.exit_code = 1;
      outputs_.Write("eval.json", [&] {
        WriteFileAtomically(outputs_.PathOf("eval.json"), RunSummaryJson(summary_));
      });
      throw;
    }
  } else {
    outcome = RunPipeline();
  }
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return Finish(outcome, elapsed);
}

void RunController::Evaluate(const std::vector<StampedPose>& trajectory) {
  RunSummary& summary = summary_;
  if (!ground_truth_.empty() && trajectory.size() >= 3) {
    try {
      const AteResult ate = ComputeAte(ground_truth_, trajectory);
      if (!std::isfinite(ate.error.rmse) || !std::isfinite(ate.error.max))
        throw std::runtime_error("the error is not a finite number");
      std::printf("ATE RMSE %.4f m (mean %.4f, median %.4f, max %.4f; %zu pairs)\n", ate.error.rmse,
                  ate.error.mean, ate.error.median, ate.error.max, ate.num_pairs);
      summary.ate = AteFigures{ate.error.rmse, ate.error.mean, ate.error.median, ate.error.max,
                               ate.num_pairs};
      // The pose each frame got when it was tracked (what a robot receives at the moment),
      // against the final trajectory above, which later bundle adjustments refined.
      const std::vector<StampedPose> online = ReadBackTrajectory("trajectory_online.txt");
      if (online.size() >= 3) {
        const AteResult online_ate = ComputeAte(ground_truth_, online);
        std::printf("online ATE RMSE %.4f m (mean %.4f, median %.4f, max %.4f; %zu pairs)\n",
                    online_ate.error.rmse, online_ate.error.mean, online_ate.error.median,
                    online_ate.error.max, online_ate.num_pairs);
        summary.online_ate =
            AteFigures{online_ate.error.rmse, online_ate.error.mean, online_ate.error.median,
                       online_ate.error.max, online_ate.num_pairs};
      }
    } catch (const std::exception& e) {  // e.g. no stamp in common: the outputs stand
      summary.ate.reset();
      summary.online_ate.reset();
      summary.ate_note = EchoValue(e.what(), 500);
      std::printf("ATE: not evaluated (%s)\n", summary.ate_note.c_str());
    }
  } else if (dataset_.has_groundtruth() && ground_truth_.empty()) {
    summary.ate_note = dataset_.groundtruth_path() + ": see the warning above";
    std::printf("ATE: not evaluated (%s)\n", summary.ate_note.c_str());
  } else if (!dataset_.groundtruth_problem().empty()) {
    summary.ate_note = EchoValue(dataset_.groundtruth_problem(), 500);
    std::printf("ATE: not evaluated (%s)\n", summary.ate_note.c_str());
  } else if (ground_truth_.empty()) {
    summary.ate_note = "no ground truth";
  } else {
    summary.ate_note = "fewer than 3 frames in the trajectory";
  }
}

void RunController::Summarize(const Outcome& outcome, size_t in_trajectory, double elapsed) {
  const RunControllerOptions& s = options_;
  summary_ = BaseSummary();
  RunSummary& summary = summary_;
  summary.processed = outcome.processed;
  if (!outcome.stamps.empty() && s.loop_minutes == 0) {
    // Frames that are not this run's (another frame source on the same DDS partition): counted
    // apart, never as this run's frames.
    std::set<Timestamp> own;
    for (size_t k = s.first; k < s.last; ++k)
      if (const auto i = dataset_.FrameForRgbEntry(k)) own.insert(dataset_.frames()[*i].rgb_stamp);
    // A stamp seen twice is another stream's too (a second run of the same sequence, a second
    // slam on the partition).
    std::set<Timestamp> seen;
    for (const Timestamp& t : outcome.stamps)
      summary.foreign_frames += own.count(t) == 0 || !seen.insert(t).second;
    summary.processed -= std::min(summary.processed, summary.foreign_frames);
  }
  summary.states = outcome.states;
  summary.in_trajectory = in_trajectory;
  summary.seconds = elapsed;
  summary.interrupted = outcome.interrupted;
  summary.component_failed = outcome.exit_code != 0;
  summary.ignored_samples = outcome.ignored_samples;
  summary.components_cut_short = outcome.components_cut_short;
  // A looped replay (--loop-minutes) lasts its minutes: one that ended sooner was cut short (the
  // run's clock starts before the player's, so a complete replay always takes longer).
  summary.loop_ended_early =
      s.loop_minutes > 0 && !outcome.interrupted && elapsed < 60.0 * s.loop_minutes;
  if (s.rate > 0 && outputs_.Fresh(kRealtimeReportFile)) {
    summary.realtime = ReadRealtimeReport(outputs_.PathOf(kRealtimeReportFile));
    // The player counts the results it timed; a pose it did not see (its reader behind after the
    // whole run was stopped and continued) is still a frame the pipeline took: frames.csv has it.
    // The frames the pipeline took are not dropped, in the summary and in realtime.txt.
    RealtimeReport& r = *summary.realtime;
    const size_t taken = std::min(r.frames, summary.processed);
    if (taken > r.results) {
      r.results = taken;
      outputs_.Write(kRealtimeReportFile,
                     [&] { WriteRealtimeReport(outputs_.PathOf(kRealtimeReportFile), r); });
    }
  }
}

void RunController::WriteLoadedMapOctoMap() {
  const RunControllerOptions& s = options_;
  RunOutputs& outputs = outputs_;
  // A --load-map run that added no keyframe (--localization, or nothing new seen) gave the mapper
  // nothing to insert: map.bt is then the loaded map's static map (its map points).
  if (s.map && !s.system.load_map.empty() && s.load_octomap.empty() && !outputs.Fresh("map.bt")) {
    size_t points = 0;
    outputs.Write("map.bt", [&] {
      points = WriteMapFileOctoMap(s.out.string(), s.system.load_map, s.system, s.octomap,
                                   /*with_full_map=*/!s.save_map.empty());
    });
    if (points > 0)
      std::printf(
          "map.bt: the static map of %s (%zu map point observations; the run added no "
          "keyframe)\n",
          s.system.load_map.c_str(), points);
  }
}

std::vector<StampedPose> RunController::ReadBackTrajectory(const std::string& name) {
  if (!outputs_.Fresh(name)) return {};
  try {
    return ReadTumTrajectory(outputs_.PathOf(name));
  } catch (const InputError& e) {
    // Written, but not a trajectory the evaluation can take (poses kilometres away: a wrong depth
    // scale). The run's other outputs and eval.json are still written; the run exits 1.
    outputs_.RecordFailure(name, std::string("written but not readable back: ") + e.what());
    return {};
  }
}

int RunController::Finish(const Outcome& outcome, double elapsed) {
  const RunControllerOptions& s = options_;
  RunOutputs& outputs = outputs_;
  WriteLoadedMapOctoMap();
  const std::vector<StampedPose> trajectory = ReadBackTrajectory("trajectory.txt");
  Summarize(outcome, trajectory.size(), elapsed);
  RunSummary& summary = summary_;
  std::printf("mode: %s%s\n", summary.mode.c_str(),
              outcome.interrupted ? " (interrupted by a signal)" : "");
  std::printf("frames: %zu processed, %zu tracked, %zu lost, %zu without depth partner; %.1f fps\n",
              outcome.processed, trajectory.size(), outcome.lost, without_depth_partner_,
              outcome.processed / std::max(elapsed, 1e-9));
  PrintPoseCounts(outcome.states, outcome.processed);
  PrintIntegrity(summary, s.loop_minutes);
  std::printf("filter: %s%s\n", s.filter.c_str(), s.system.deterministic ? " (deterministic)" : "");
  if (summary.realtime) std::printf("real time: %s\n", summary.realtime->Summary().c_str());
  Evaluate(trajectory);
  if (!outcome.ignored_samples_note.empty())
    std::printf("dds: %s\n", outcome.ignored_samples_note.c_str());
  // The exit code, then eval.json (which holds it), then the list of what was written.
  const bool incomplete =
      !outcome.interrupted &&
      ((s.loop_minutes == 0 &&
        (summary.processed + DroppedByRate(summary) < requested_ || summary.foreign_frames > 0)) ||
       summary.loop_ended_early || !summary.components_cut_short.empty());
  const bool tracking_failure =
      !outcome.interrupted && IsTrackingFailure(outcome.processed, trajectory.size());
  // Frames of another source explain a failed component (the run's player, whose frames the
  // consumers refused): that reason first.
  const bool mixed = incomplete && summary.foreign_frames > 0;
  // The summary printed so far must have reached stdout's reader (`> /dev/full`): eval.json
  // holds the exit code the command will end with.
  const std::string stdout_error = StandardOutputError();
  if (!stdout_error.empty())
    summary.error += (summary.error.empty() ? "" : "; ") +
                     std::string("cannot write to standard output: ") + stdout_error;
  summary.exit_code = !outputs.failures().empty() || !stdout_error.empty() ? 1
                      : mixed                                              ? kExitIncompleteRun
                      : outcome.exit_code != 0                             ? 1
                      : incomplete                                         ? kExitIncompleteRun
                      : tracking_failure                                   ? 1
                                                                           : 0;
  // A failed component's message is on stderr (its own line); eval.json says that one failed.
  if (summary.exit_code == 1 && summary.error.empty() && summary.component_failed)
    summary.error = "a component of the run failed (its error is on stderr)";
  // An output that could not be written is the run's error (eval.json says why it exits 1).
  for (const auto& [name, reason] : outputs.failures())
    summary.error += (summary.error.empty() ? "" : "; ") + name + " not written: " + reason;
  outputs.Write("eval.json",
                [&] { WriteFileAtomically(outputs.PathOf("eval.json"), RunSummaryJson(summary)); });
  PrintOutputs(outputs);
  return ReportExit(outcome, trajectory.size(), incomplete, tracking_failure, elapsed);
}

int RunController::ReportExit(const Outcome& outcome, size_t in_trajectory, bool incomplete,
                              bool tracking_failure, double elapsed) const {
  const RunControllerOptions& s = options_;
  const RunOutputs& outputs = outputs_;
  const RunSummary& summary = summary_;
  if (!outputs.failures().empty()) {
    std::fprintf(stderr, "%s", outputs.FailureReport("run").c_str());
    std::fprintf(stderr,
                 outputs.FreshNames().empty()
                     ? "dygslam run: no output could be written; exit 1\n"
                     : "dygslam run: the other outputs are written (see the list above); exit 1\n");
    return 1;
  }

  // Fewer frames than requested, without a stop the user gave (Ctrl-C, SIGTERM): the stream was
  // cut short (a peer gone, an end of stream from outside, a stalled component). Its outputs are
  // written, but the run is not the one asked for: a distinct exit code.
  // A camera-paced run (--rate) drops frames by design (realtime.txt counts them).
  if (incomplete && summary.foreign_frames > 0) {
    std::fprintf(stderr,
                 "dygslam run: error: %zu of the processed frames are not this run's or came twice "
                 "(another frame source or a second slam publishes on its DDS partition): the "
                 "outputs mix two streams; "
                 "exit %d\n",
                 summary.foreign_frames, kExitIncompleteRun);
    return kExitIncompleteRun;
  }
  if (outcome.exit_code != 0) {
    std::fprintf(stderr, "dygslam run: a pipeline component failed (see the messages above)\n");
    return 1;
  }
  if (incomplete && !summary.components_cut_short.empty()) {
    std::string names;
    for (const std::string& c : summary.components_cut_short)
      names += (names.empty() ? "" : ", ") + c;
    std::fprintf(stderr,
                 "dygslam run: error: incomplete part: %s (a component ended before the run "
                 "did, or what it published did not all arrive: map.bt for the mapper and "
                 "slam's keyframes, the boxes for the detector, lack the rest); exit %d\n",
                 names.c_str(), kExitIncompleteRun);
    return kExitIncompleteRun;
  }
  if (incomplete && summary.loop_ended_early) {
    std::fprintf(stderr,
                 "dygslam run: error: the replay ended after %.0f s of the %g minutes asked for "
                 "(--loop-minutes): the stream was cut short (a component stopped or stalled, or "
                 "an end of stream came from outside the run); exit %d\n",
                 elapsed, s.loop_minutes, kExitIncompleteRun);
    return kExitIncompleteRun;
  }
  if (incomplete) {
    std::printf("run incomplete: %zu of the %zu requested frames processed (%zu missing)\n",
                summary.processed, requested_, requested_ - summary.processed);
    std::fprintf(stderr,
                 "dygslam run: error: the run ended with %zu of the %zu requested frames (rgb.txt "
                 "entries %zu to %zu with a depth partner): the stream was cut short (a component "
                 "stopped or stalled, or an end of stream came from outside the run); exit %d\n",
                 summary.processed, requested_, s.first, s.last, kExitIncompleteRun);
    return kExitIncompleteRun;
  }
  // A run that tracked (almost) nothing has no trajectory to speak of: fail, and say why.
  if (tracking_failure) {
    PrintTrackingFailure("run", outcome.processed, in_trajectory, outcome.lost);
    return 1;
  }
  return 0;
}

}  // namespace dygslam
