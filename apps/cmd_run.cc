// dygslam run DATASET_DIR [--config FILE] [--filter none|boxes|geometry|paper|full]
//              [--frames FIRST:LAST]
//              [--out DIR] [--deterministic] [--processes | --direct] [--no-map] [--domain N]
//              [--quiet]
//
// Three ways to run the same SLAM, same outputs in DIR (trajectory.txt, keyframes.txt, frames.csv,
// map.bt unless --no-map) and the same summary on stdout:
//   default      the DDS pipeline (player, detector, slam, mapper, recorder) on threads of this
//                process (components/pipeline.h, RunPipeline); needs a build with DDS, else
//                falls back to --direct and says so
//   --processes  the DDS pipeline, one process per component
//   --direct     no DDS: this process feeds the System frame by frame (the library loop), the map
//                is built by a KeyframeMapper thread
// SIGINT / SIGTERM stop the run at any time: outputs are flushed (atomically) and the exit code
// is 0.
#include <octomap/OcTree.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <stdexcept>

#include "apps/command.h"
#include "core/base/echo.h"
#include "core/base/error.h"
#include "core/base/log.h"
#include "core/base/stop_signal.h"
#include "core/config/settings.h"
#include "core/dynamic/yolo_detector.h"
#include "core/eval/trajectory_eval.h"
#include "core/io/dataset.h"
#include "core/io/detections_io.h"
#include "core/io/file_util.h"
#include "core/io/trajectory_io.h"
#include "core/system/system.h"
#include "mapping/keyframe_mapper.h"
#include "mapping/octomap_builder.h"
#include "run/dataset_runner.h"
#include "run/realtime_report.h"
#include "run/run_outputs.h"
#include "run/run_settings.h"
#include "run/run_summary.h"
#ifdef DYGSLAM_HAVE_COMPONENTS
#include "components/pipeline.h"
#endif

namespace dygslam::cli {
namespace {
namespace fs = std::filesystem;

// The frames a camera-paced run (--rate) dropped by design: those the pipeline could not take in
// time (realtime.txt). Missing frames beyond them were cut short.
// A stall (no result for seconds while frames arrived: a component paused) explains none.
size_t DroppedByRate(const RunSummary& summary) {
  return summary.realtime && !summary.realtime->Stalled() ? summary.realtime->dropped() : 0;
}

// --rate above 0: the slowest replay that is still a replay (0.01x = a 30 Hz frame every 3.3 s).
constexpr double kMinRate = 0.01;

struct RunSetup {
  std::string dataset_dir;
  std::string config;
  SystemOptions system;
  OctoMapOptions octomap;
  size_t first = 0, last = 0;
  fs::path out;
  bool map = true;
  bool progress = true;
  double loop_minutes = 0;  // DDS modes: player replays the frames (soak)
  double rate = 0;          // --rate: frames arrive as from a camera at this many times real time
  // --detections FILE: boxes from a file (e.g. the ground-truth boxes of `dygslam synth`, or an
  // external detector) instead of the internal detector. Direct mode only.
  std::map<Timestamp, std::vector<Detection>> detections;
  bool use_detection_file = false;
  std::string save_map;      // --save-map FILE: the SLAM map at the end (also on a stop signal)
  std::string load_octomap;  // --load-octomap FILE: the OctoMap the map continues
};

struct RunOutcome {
  size_t processed = 0;
  size_t lost = 0;
  std::map<std::string, size_t> states;  // frames per tracking state (frames.csv `state`)
  bool interrupted = false;
  int exit_code = 0;
  size_t ignored_samples = 0;  // DDS: samples of writers outside this run (components/protocol.h)
  std::vector<std::string> components_cut_short;  // --processes: ended before the run did
  std::vector<Timestamp> stamps;  // DDS: the stamps of the frames processed (frames.csv)
};

RunOutcome RunDirect(const RunSetup& s, const RgbdDataset& dataset, RunOutputs& outputs) {
  RunOutcome outcome;
  System system(s.system);
  std::unique_ptr<KeyframeMapper> mapper;
  if (s.map) {
    mapper = std::make_unique<KeyframeMapper>(s.system.camera, s.octomap);
    if (!s.load_octomap.empty()) {
      const auto base = ReadOctoMap(s.load_octomap);
      mapper->WithBuilder([&](OctoMapBuilder& b) { b.SetBaseMap(*base, s.load_octomap); });
    }
    KeyframeMapper* m = mapper.get();
    system.SetKeyframeCallback([m](const KeyframeData& k) { m->Submit(k); });
  }
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
  std::string csv = FramesCsvHeader();
  std::vector<StampedPose> online;  // the pose known when each frame was tracked
  const auto t0 = std::chrono::steady_clock::now();
  const size_t total = s.last - s.first;
  size_t done = 0, lost = 0;  // for the progress line
  // A bad input found mid-run (an image that does not decode) ends the loop, but what the frames
  // before it gave is written below like on a stop signal; then the error is reported (exit 1).
  std::exception_ptr failure;
  DatasetRunSummary summary;
  try {
    summary = RunDatasetFrames(dataset, system, run, [&](size_t k, const FrameResult& r) {
      ++done;
      if (r.state == TrackingState::kLost) ++lost;
      if (r.world_from_cam) online.push_back({r.stamp, *r.world_from_cam});
      ++outcome.states[ToString(r.state)];
      csv += FramesCsvRow(FrameRowFromResult(r));
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
  if (s.rate > 0) {
    const double fps = s.system.sensor.fps > 0 ? s.system.sensor.fps : 30.0;
    const double late_after_ms = kLateFramePeriods * 1000.0 / (fps * s.rate);
    outputs.Write(kRealtimeReportFile, [&] {
      WriteRealtimeReport(outputs.PathOf(kRealtimeReportFile),
                          MakeRealtimeReport(s.rate, summary.processed + summary.dropped,
                                             summary.latency_ms, late_after_ms));
    });
  }
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
  {
    LocalMappingStats lm = system.LocalMappingStatistics();
    std::vector<double> ms = lm.per_keyframe_ms;
    double median = 0;
    if (!ms.empty()) {
      std::nth_element(ms.begin(), ms.begin() + ms.size() / 2, ms.end());
      median = ms[ms.size() / 2];
    }
    std::printf(
        "local mapping: %d keyframes, median %.1f ms per keyframe, %d points triangulated, "
        "%d keyframes culled\n",
        lm.keyframes_processed, median, lm.points_triangulated, lm.keyframes_culled);
    {
      auto median_of = [](std::vector<double> v) {
        if (v.empty()) return 0.0;
        std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
        return v[v.size() / 2];
      };
      std::vector<double> kfs(lm.ba_keyframes.begin(), lm.ba_keyframes.end());
      std::vector<double> obs(lm.ba_observations.begin(), lm.ba_observations.end());
      std::printf("local BA: median %.0f keyframes optimised, %.0f observations\n", median_of(kfs),
                  median_of(obs));
      std::printf(
          "local mapping schedule: local BA solve median %.1f ms, in tracking's thread median "
          "%.1f ms per keyframe; %d local BAs late (tracking waited %.0f ms in all), %d landed "
          "early (next keyframe)\n",
          median_of(lm.solve_ms), median_of(lm.insert_ms), lm.late_bundle_adjustments,
          lm.late_wait_ms, lm.early_landings);
    }
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
  RecreateOutputDirIfRemoved("run", "out", s.out);
  // A run that processed no frame (stopped or failed before the first) has no trajectory: an
  // earlier run's files stay as they were (listed apart in the summary), not replaced by empty
  // ones; where there is none, the empty (loadable) files are written.
  std::error_code exists_error;
  if (outcome.processed > 0 || !fs::exists(outputs.PathOf("trajectory.txt"), exists_error)) {
    outputs.Write("frames.csv", [&] { WriteFileAtomically(outputs.PathOf("frames.csv"), csv); });
    outputs.Write("trajectory.txt", [&] {
      WriteTumTrajectory(outputs.PathOf("trajectory.txt"), system.Trajectory());
    });
    outputs.Write("keyframes.txt", [&] {
      WriteTumTrajectory(outputs.PathOf("keyframes.txt"), system.KeyframeTrajectory());
    });
    outputs.Write("trajectory_online.txt",
                  [&] { WriteTumTrajectory(outputs.PathOf("trajectory_online.txt"), online); });
  }
  // With --save-map, map.ot too (the OctoMap with probabilities, what --load-octomap continues).
  if (mapper) {
    outputs.Write("map.bt", [&] {  // a failure before the files (the mapper's) is map.bt's
      WriteMapperBinary(outputs, *mapper, /*with_full_map=*/!s.save_map.empty());
    });
  }
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

// Lines of a class names file that name a class (0 when there is no such file).
int CountClassNames(const std::string& path) {
  std::error_code ec;
  if (path.empty() || !fs::is_regular_file(path, ec)) return 0;
  std::ifstream in(path);
  int n = 0;
  for (std::string line; std::getline(in, line);) {
    if (line.find_first_not_of(" \t\r") != std::string::npos) ++n;
  }
  return n;
}

// --detections: a file whose stamps match no frame (another sequence, stamps in another unit)
// would run the filter without any box, silently, and so would boxes outside the image. Warns
// with the counts.
void WarnUnmatchedDetections(const std::string& path, const RunSetup& s,
                             const RgbdDataset& dataset) {
  size_t frames = 0, frames_with_boxes = 0;
  for (size_t k = s.first; k < s.last; ++k) {
    const auto index = dataset.FrameForRgbEntry(k);
    if (!index) continue;
    ++frames;
    if (!DetectionsNear(s.detections, dataset.frame(*index).rgb_stamp).empty()) ++frames_with_boxes;
  }
  size_t stamps_unmatched = 0;
  for (const auto& [stamp, boxes] : s.detections) {
    bool matched = false;
    for (const RgbdFrameEntry& f : dataset.frames()) {
      if (std::abs(SecondsBetween(stamp, f.rgb_stamp)) <= 0.02) {
        matched = true;
        break;
      }
    }
    if (!matched) ++stamps_unmatched;
  }
  // Boxes that do not overlap the image (pixels in another resolution, a unit mix-up) mask
  // nothing: said, with how many.
  size_t boxes = 0, boxes_outside = 0;
  const cv::Rect2f image(0.f, 0.f, static_cast<float>(s.system.camera.width),
                         static_cast<float>(s.system.camera.height));
  for (const auto& [stamp, frame_boxes] : s.detections) {
    for (const Detection& d : frame_boxes) {
      ++boxes;
      if ((d.box & image).area() <= 0.f) ++boxes_outside;
    }
  }
  if (boxes_outside > 0) {
    std::fprintf(stderr,
                 "dygslam run: warning: --detections %s: %zu of its %zu boxes lie outside the "
                 "%dx%d image (Camera.width x Camera.height) and mask nothing\n",
                 EchoValue(path).c_str(), boxes_outside, boxes, s.system.camera.width,
                 s.system.camera.height);
  }
  if (stamps_unmatched == 0 && (frames_with_boxes > 0 || s.detections.empty())) return;
  std::fprintf(stderr,
               "dygslam run: warning: --detections %s: %zu of its %zu stamps match no frame of "
               "the dataset (within 0.02 s); %zu of the run's %zu frames have boxes, %zu have "
               "none%s\n",
               EchoValue(path).c_str(), stamps_unmatched, s.detections.size(), frames_with_boxes,
               frames, frames - frames_with_boxes,
               frames_with_boxes == 0 ? " (the file matches no frame: no box is used; is it of "
                                        "another sequence?)"
                                      : "");
}

#ifdef DYGSLAM_HAVE_COMPONENTS
// A partition name unique to this run: concurrent runs on one DDS domain never mix.
std::string RunPartition() {
  char host[64] = {0};
  gethostname(host, sizeof(host) - 1);
  std::random_device rd;
  return "dygslam_run_" + std::string(host) + "_" + std::to_string(getpid()) + "_" +
         std::to_string(rd() % 100000);
}

RunOutcome RunThroughPipeline(const RunSetup& s, bool processes, int domain_id,
                              const std::string& partition, const std::string& security_dir,
                              const RunOutputs& outputs) {
  PipelineOptions o;
  o.dataset_dir = s.dataset_dir;
  o.output_dir = s.out.string();
  o.settings_path = s.config;
  o.system = s.system;
  o.octomap = s.octomap;
  o.first_entry = s.first;
  o.last_entry = s.last;
  o.processes = processes;
  o.run_mapper = s.map;
  o.domain_id = domain_id;
  o.partition = partition.empty() ? RunPartition() : partition;
  o.security_dir = security_dir;
  std::fprintf(stderr, "[run] DDS partition '%s' (a bridge joins with --partition %s)\n",
               EchoValue(o.partition).c_str(), EchoValue(o.partition).c_str());
  o.progress = s.progress;
  o.loop_minutes = s.loop_minutes;
  o.rate = s.rate;
  if (s.rate > 0) o.window = 0;  // a camera does not wait for the pipeline
  o.save_map = s.save_map;
  o.load_octomap = s.load_octomap;
  RunOutcome outcome;
  // Nothing in DIR is deleted up front: the components replace each file atomically when theirs
  // is complete, and a file an earlier run left is told apart by its version (RunOutputs).
  StopReport report;
  outcome.exit_code = RunPipeline(o, &report);
  outcome.interrupted = report.signaled;
  outcome.ignored_samples = report.ignored_samples;
  outcome.components_cut_short = report.components_cut_short;
  if (outputs.Fresh("frames.csv")) {
    for (const TextLine& line : ReadDataLines(outputs.PathOf("frames.csv"))) {
      if (line.tokens.size() < 2 || line.tokens[0] == "stamp") continue;
      ++outcome.processed;
      if (line.tokens[1] == ToString(TrackingState::kLost)) ++outcome.lost;
      ++outcome.states[line.tokens[1]];
      if (const std::optional<Timestamp> t = Timestamp::Parse(line.tokens[0]))
        outcome.stamps.push_back(*t);
    }
  }
  return outcome;
}
#endif

// The files a run writes (--save-map first), for the clash checks against its inputs.
int RunRun(const std::vector<std::string>& args) {
  ArgParser p(
      "run",
      "DATASET_DIR [--config FILE] [--filter none|boxes|geometry|paper|full] [--frames FIRST:LAST] "
      "[--out DIR] "
      "[--deterministic] [--processes | --direct] [--no-map]",
      "Runs the SLAM on a TUM/Bonn dataset folder; writes DIR/trajectory.txt (TUM format, every "
      "tracked\n"
      "frame), DIR/keyframes.txt, DIR/frames.csv (state and stage times per frame) and DIR/map.bt\n"
      "(OctoMap of the static scene). Default: the DDS components (player, detector, slam, "
      "mapper,\n"
      "recorder) on threads of this process; --processes: one process per component; --direct: no\n"
      "DDS, the library loop. SIGINT / SIGTERM: outputs are flushed, exit 0.");
  p.AddPositional("DATASET_DIR", "folder with rgb.txt, depth.txt (groundtruth.txt optional)");
  p.AddOption("config", "FILE",
              "settings YAML (ORB-SLAM2 keys); default: DATASET_DIR/camera.yaml or a preset");
  p.AddOption("filter", "MODE",
              "dynamic filter: none | boxes | geometry | full | paper (+margin, +margin+demotion)",
              "full");
  p.AddOption("frames", "FIRST:LAST",
              "rgb.txt entries FIRST (inclusive, 0-based) to LAST (exclusive)");
  p.AddOption("out", "DIR", "output folder", "out/run");
  p.AddFlag("deterministic",
            "fixed seeds and synchronous local mapping: identical output run to run");
  p.AddFlag("processes", "DDS pipeline with each component in its own process");
  p.AddFlag("direct", "no DDS: feed the System directly in this process");
  p.AddFlag("no-map", "do not build map.bt");
  p.AddOption("detections", "FILE",
              "boxes per frame from FILE ('timestamp x y w h class score', e.g. detections.txt of\n"
              "`dygslam synth`) instead of the detector; implies --direct");
  p.AddOption("domain", "N", "DDS domain id (default: $DYGSLAM_DOMAIN_ID or 0)", "-1");
  p.AddOption("partition", "NAME",
              "DDS partition of the pipeline topics (default: unique per run)");
  const char* security_env = std::getenv("DYGSLAM_DDS_SECURITY_DIR");
  p.AddOption("security", "DIR",
              "DDS Security: make_dds_certs.sh's OUT_DIR (one identity folder per component) or "
              "one identity folder (default: $DYGSLAM_DDS_SECURITY_DIR; none = off)",
              security_env != nullptr ? security_env : "");
  p.AddOption(
      "rate", "R",
      "play the frames as a camera would, at R times the dataset's frame rate (1: real\n"
      "time, 0.01 to 1000); frames the pipeline cannot take in time are dropped and\n"
      "counted, latency is measured (OUT/realtime.txt). 0: as fast as the pipeline takes them",
      "0");
  p.AddOption("loop-minutes", "M",
              "DDS modes: the player replays the frames for M minutes, stamps continuing (soak)",
              "0");
  AddDatasetRunFlags(&p);
  p.AddOption("save-map", "FILE",
              "write the SLAM map (keyframes, points, BoW) to FILE at the end, also when stopped");
  p.AddOption("load-map", "FILE",
              "start from the SLAM map in FILE (made with the same camera, ORB and vocabulary);\n"
              "without --localization it is extended");
  p.AddFlag("localization",
            "with --load-map: track against the loaded map without adding keyframes or points");
  p.AddOption("load-octomap", "FILE",
              "continue this OctoMap (.ot, e.g. map.ot of a --save-map run): keyframes are\n"
              "inserted on top; in --localization it is the map");
  if (!p.Parse(args)) return p.exit_code();
  if (!CheckFilterOption(&p)) return 2;
  if (p.Flag("processes") && p.Flag("direct"))
    return p.UsageError("--processes and --direct exclude each other");
  if (p.Has("security") && (p.Flag("direct") || p.Has("detections")))
    return p.UsageError(
        "--security secures the DDS pipeline; --direct and --detections use no DDS");
  if (!p.Has("security") && security_env != nullptr && *security_env != '\0' &&
      (p.Flag("direct") || p.Has("detections"))) {
    std::fprintf(stderr,
                 "dygslam run: warning: DYGSLAM_DDS_SECURITY_DIR is set but --direct uses no DDS "
                 "(nothing to secure)\n");
  }
  if (p.Get("partition").find_first_of("*?[]") != std::string::npos)
    return p.UsageError("--partition '" + EchoValue(p.Get("partition")) +
                        "': wildcards (* ? [ ]) would join other runs; give a plain name");
  if (p.Flag("strict-settings")) ::setenv("DYGSLAM_STRICT_SETTINGS", "1", 1);  // --processes
  // The output folder first: a bad --out is found before the run, not after it.
  const fs::path out_dir = PrepareOutputDir("out", p.Get("out"));

  RunSetup s;
  s.dataset_dir = p.Positional("DATASET_DIR");
  s.config = p.Has("config") ? p.Get("config") : DefaultSettingsPath(s.dataset_dir, ConfigDir());
  {
    const RunConfiguration c =
        LoadRunConfiguration({s.config, CliSettingsReadOptions(p.Flag("strict-settings")),
                              p.Get("filter"), p.Flag("deterministic")});
    s.system = c.system;
    s.octomap = c.octomap;
  }
  ::setenv("DYGSLAM_SETTINGS_WARNED", "1", 1);  // --processes: components do not repeat them
  // No output may replace an input or another output: checked before any work (exit 2).
  if (const std::string clash = FindDatasetRunOutputClash(
          DatasetRunInputs(p, p.Positional("DATASET_DIR"),
                           p.Has("config") ? "--config" : "the settings file", s.config, s.system,
                           {"load-map", "load-octomap", "detections"}),
          p, out_dir);
      !clash.empty())
    return p.UsageError(clash);
  s.map = !p.Flag("no-map");
  if (p.Flag("localization") && !p.Has("load-map"))
    return p.UsageError("--localization needs --load-map FILE");
  if (p.Has("save-map")) {
    s.save_map = p.Get("save-map");
    CheckMapFileWritable(s.save_map);
  }
  if (p.Has("load-octomap")) {
    if (!s.map) return p.UsageError("--load-octomap and --no-map exclude each other");
    s.load_octomap = p.Get("load-octomap");
    try {  // checked before any work (InputError naming the option and the file)
      ReadOctoMap(s.load_octomap);
    } catch (const InputError& e) {
      throw InputError(std::string("--load-octomap: ") + e.what());
    }
  }
  if (p.Has("load-map")) {
    // Checked before any work: a bad map is an error naming the file, no output is written.
    s.system.load_map = p.Get("load-map");
    s.system.localization = p.Flag("localization");
    std::printf("map file: loaded %s (%s)%s\n", s.system.load_map.c_str(),
                DescribeMapFile(CheckMapFile(s.system.load_map, s.system)).c_str(),
                s.system.localization ? ", localization mode" : "");
  }
  if (p.Has("detections")) {
    if (p.Flag("processes")) return p.UsageError("--detections works with --direct only");
    // Class ids are checked against the detector's classes (its names file) when it is found.
    DetectorOptions names_of = s.system.detector;
    if (names_of.names_path.empty()) {
      try {
        names_of = DetectorOptionsForModel("yolo-fastest-1.1");
      } catch (const InputError&) {  // no models here: class ids are not checked
      }
    }
    const int num_classes = CountClassNames(names_of.names_path);
    s.detections = ReadDetections(p.Get("detections"), num_classes, names_of.names_path);
    s.use_detection_file = true;
  }
  s.progress = !p.Flag("quiet");
  int domain_id = -1;
  if (!p.GetNumber("rate", 0, 1000, &s.rate) ||
      !p.GetNumber("loop-minutes", 0, 1e6, &s.loop_minutes) ||
      !p.GetInt("domain", -1, 232, &domain_id))
    return p.exit_code();
  // Below 0.01x a 30 Hz sequence waits more than 3 s per frame: a mistyped rate, not a replay.
  if (s.rate > 0 && s.rate < kMinRate) {
    return p.UsageError("--rate " + p.Get("rate") +
                        ": must be 0 (as fast as the pipeline takes "
                        "the frames) or between 0.01 and 1000");
  }
  if (s.loop_minutes > 0 && p.Flag("direct"))
    return p.UsageError("--loop-minutes works with the DDS modes only (not --direct)");

  DatasetOptions dataset_options;
  dataset_options.refuse_outside_paths = p.Flag("strict-paths");
  const RgbdDataset dataset = RgbdDataset::Open(s.dataset_dir, dataset_options);
  {
    // Nor a dataset image (a --save-map onto rgb/….png would destroy it): checked once the
    // lists are read, before any work (exit 2).
    std::vector<NamedPath> images;
    images.reserve(2 * dataset.frames().size());
    for (const RgbdFrameEntry& f : dataset.frames()) {
      images.push_back({"the dataset's image listed at " + f.rgb_listed_at, f.rgb_path});
      images.push_back({"the dataset's image listed at " + f.depth_listed_at, f.depth_path});
    }
    // And every file in its image folders (entries without a partner are not in frames()).
    for (const char* folder : {"rgb", "depth"}) {
      std::error_code ec;
      for (fs::directory_iterator it(fs::path(s.dataset_dir) / folder, ec), end; !ec && it != end;
           it.increment(ec))
        images.push_back(
            {std::string("a file of the dataset's ") + folder + "/ folder", it->path().string()});
    }
    if (const std::string clash = FindOutputAmongInputs(images, DatasetRunOutputs(p, out_dir));
        !clash.empty())
      return p.UsageError(clash);
  }
  if (const std::string foreign = FindForeignFileAtSaveMap(p); !foreign.empty())
    return p.UsageError(foreign);
  // The folder the map goes into is the one there now, even if it is replaced while the run goes.
  if (p.Has("save-map")) PinFolderOfOutput(p.Get("save-map"));
  if (const std::string foreign = FindForeignFileInRunOutputs(out_dir); !foreign.empty())
    return p.UsageError(foreign);
  s.first = 0;
  s.last = dataset.num_rgb_entries();
  std::string frames_note;  // --frames beyond the dataset: cut, with a warning
  if (p.Has("frames")) {
    try {  // a malformed or out-of-range --frames is a usage error (exit 2), as other numbers
      std::tie(s.first, s.last) =
          ParseFrameRange(p.Get("frames"), dataset.num_rgb_entries(), &frames_note);
    } catch (const std::exception& e) {
      return p.UsageError(e.what());
    }
  }
  if (!frames_note.empty()) std::fprintf(stderr, "dygslam run: warning: %s\n", frames_note.c_str());
  // The ground truth is optional and only scores the run: a malformed groundtruth.txt is found
  // here, before any frame, and the run goes on without evaluation (its trajectory is what
  // matters; `dygslam eval` scores it once the file is fixed).
  std::vector<StampedPose> groundtruth;
  if (dataset.has_groundtruth()) {
    try {
      groundtruth = ReadTumTrajectory(dataset.groundtruth_path());
    } catch (const InputError& e) {
      groundtruth.clear();
      std::fprintf(stderr,
                   "dygslam run: warning: %s; the run goes on without evaluation (fix the file, "
                   "then `dygslam eval GROUNDTRUTH OUT/trajectory.txt`)\n",
                   e.what());
    }
  } else if (!dataset.groundtruth_problem().empty()) {
    std::fprintf(stderr,
                 "dygslam run: warning: %s; the run goes on without evaluation (replace it by "
                 "the ground truth file, then `dygslam eval GROUNDTRUTH OUT/trajectory.txt`)\n",
                 EchoValue(dataset.groundtruth_problem(), 500).c_str());
  }
  if (s.use_detection_file) WarnUnmatchedDetections(p.Get("detections"), s, dataset);
  WarnAboutDataset("run", dataset, s.first, s.last, s.system.sensor.depth_map_factor,
                   s.system.camera.width, s.system.camera.height,
                   groundtruth.empty() ? nullptr : &groundtruth);
  size_t skipped = 0;
  for (size_t k = s.first; k < s.last; ++k) {
    if (!dataset.FrameForRgbEntry(k)) ++skipped;
  }
  const size_t requested = s.last - s.first - skipped;  // frames with a depth partner
  if (skipped > 0) {
    // Said before the run, not only counted in the summary: a depth.txt cut short or with a gap
    // leaves frames out without any other sign.
    std::fprintf(stderr,
                 "dygslam run: warning: %zu of the %zu rgb.txt entries %zu to %zu have no depth "
                 "image to pair with (depth.txt / associations): they are left out, %zu frames "
                 "requested\n",
                 skipped, s.last - s.first, s.first, s.last, requested);
  }
  s.out = out_dir;

  bool direct = p.Flag("direct") || s.use_detection_file;
#ifndef DYGSLAM_HAVE_COMPONENTS
  direct = true;
#endif
  // The detector's model files before any output: missing models fail here, nothing written.
  if (direct && !s.use_detection_file) ResolveDetectorModel(&s.system);

  // This run's outputs: written atomically, nothing deleted up front (see RunOutputs).
  RunOutputs outputs(s.out, RunOutputNames());
  if (!s.save_map.empty()) outputs.AddFile(s.save_map);
  std::string mode;
  RunOutcome outcome;
  const auto t0 = std::chrono::steady_clock::now();
#ifdef DYGSLAM_HAVE_COMPONENTS
  if (!p.Flag("direct") && !s.use_detection_file) {
    mode = p.Flag("processes") ? "DDS pipeline, one process per component"
                               : "DDS pipeline, one process";
    outcome = RunThroughPipeline(s, p.Flag("processes"), domain_id, p.Get("partition"),
                                 p.Get("security"), outputs);
  }
#else
  if (p.Flag("processes")) {
    throw InvalidOptions(
        "--processes: this build has no DDS components (configure with -DDYGSLAM_BUILD_DDS=ON)");
  }
  if (!p.Flag("direct")) {
    std::fprintf(
        stderr,
        "[run] this build has no DDS components: running the direct library loop (--direct)\n");
  }
#endif
  // What every summary of this run holds, whatever its end.
  const auto summary_of_run = [&] {
    RunSummary r;
    r.mode = mode;
    r.filter = p.Get("filter");
    r.deterministic = s.system.deterministic;
    r.first = s.first;
    r.last = s.last;
    r.requested = requested;
    r.without_depth_partner = skipped;
    return r;
  };
  if (mode.empty()) {
    mode = "direct (no DDS)";
    try {
      outcome = RunDirect(s, dataset, outputs);
    } catch (const std::exception& e) {
      // Stopped by an error (a corrupt image mid-run): the outputs of the frames before it are
      // written; eval.json says so, so that an earlier run's stays no longer beside them.
      RunSummary failed = summary_of_run();
      if (outputs.Fresh("frames.csv"))
        failed.processed = ReadDataLines(outputs.PathOf("frames.csv")).size() - 1;
      failed.error = e.what();
      failed.ate_note = "not evaluated: the run stopped on an error";
      failed.exit_code = 1;
      outputs.Write("eval.json", [&] {
        WriteFileAtomically(outputs.PathOf("eval.json"), RunSummaryJson(failed));
      });
      throw;
    }
  }
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
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

  const fs::path trajectory_path = outputs.PathOf("trajectory.txt");
  const std::vector<StampedPose> trajectory = outputs.Fresh("trajectory.txt")
                                                  ? ReadTumTrajectory(trajectory_path.string())
                                                  : std::vector<StampedPose>{};
  RunSummary summary = summary_of_run();
  summary.processed = outcome.processed;
  if (!outcome.stamps.empty() && s.loop_minutes == 0) {
    // Frames that are not this run's (another frame source on the same DDS partition): counted
    // apart, never as this run's frames.
    std::set<Timestamp> own;
    for (size_t k = s.first; k < s.last; ++k)
      if (const auto i = dataset.FrameForRgbEntry(k)) own.insert(dataset.frames()[*i].rgb_stamp);
    // A stamp seen twice is another stream's too (a second run of the same sequence, a second
    // slam on the partition).
    std::set<Timestamp> seen;
    for (const Timestamp& t : outcome.stamps)
      summary.foreign_frames += own.count(t) == 0 || !seen.insert(t).second;
    summary.processed -= std::min(summary.processed, summary.foreign_frames);
  }
  summary.states = outcome.states;
  summary.in_trajectory = trajectory.size();
  summary.seconds = elapsed;
  summary.interrupted = outcome.interrupted;
  summary.component_failed = outcome.exit_code != 0;
  summary.ignored_samples = outcome.ignored_samples;
  summary.components_cut_short = outcome.components_cut_short;
  // A looped replay (--loop-minutes) lasts its minutes: one that ended sooner was cut short (the
  // run's clock starts before the player's, so a complete replay always takes longer).
  summary.loop_ended_early =
      s.loop_minutes > 0 && !outcome.interrupted && elapsed < 60.0 * s.loop_minutes;
  if (s.rate > 0 && outputs.Fresh(kRealtimeReportFile))
    summary.realtime = ReadRealtimeReport(outputs.PathOf(kRealtimeReportFile));
  std::printf("mode: %s%s\n", mode.c_str(),
              outcome.interrupted ? " (interrupted by a signal)" : "");
  std::printf("frames: %zu processed, %zu tracked, %zu lost, %zu without depth partner; %.1f fps\n",
              outcome.processed, trajectory.size(), outcome.lost, skipped,
              outcome.processed / std::max(elapsed, 1e-9));
  {
    // Frames with a pose by how it was obtained: ok / fallback / relocalized; lost and
    // not_initialized frames have none.
    auto count = [&](TrackingState state) {
      auto it = outcome.states.find(ToString(state));
      return it == outcome.states.end() ? size_t{0} : it->second;
    };
    const size_t with_pose = count(TrackingState::kOk) + count(TrackingState::kFallback) +
                             count(TrackingState::kRelocalized);
    std::printf(
        "poses: %zu of %zu frames (%.1f %%): ok %zu, fallback %zu, relocalized %zu, lost %zu, "
        "not initialised %zu\n",
        with_pose, outcome.processed, 100.0 * with_pose / std::max<size_t>(outcome.processed, 1),
        count(TrackingState::kOk), count(TrackingState::kFallback),
        count(TrackingState::kRelocalized), count(TrackingState::kLost),
        count(TrackingState::kNotInitialized));
  }
  if (s.loop_minutes > 0) {
    std::printf(
        "integrity: %zu frames processed (the %zu requested frames replayed for %g min)%s\n",
        summary.processed, summary.requested, s.loop_minutes,
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
  std::printf("filter: %s%s\n", p.Get("filter").c_str(),
              s.system.deterministic ? " (deterministic)" : "");
  if (summary.realtime) std::printf("real time: %s\n", summary.realtime->Summary().c_str());
  if (!groundtruth.empty() && trajectory.size() >= 3) {
    try {
      const AteResult ate = ComputeAte(groundtruth, trajectory);
      if (!std::isfinite(ate.error.rmse) || !std::isfinite(ate.error.max))
        throw std::runtime_error("the error is not a finite number");
      std::printf("ATE RMSE %.4f m (mean %.4f, median %.4f, max %.4f; %zu pairs)\n", ate.error.rmse,
                  ate.error.mean, ate.error.median, ate.error.max, ate.num_pairs);
      summary.ate = AteFigures{ate.error.rmse, ate.error.mean, ate.error.median, ate.error.max,
                               ate.num_pairs};
      // The pose each frame got when it was tracked (what a robot receives at the moment),
      // against the final trajectory above, which later bundle adjustments refined.
      const fs::path online_path = outputs.PathOf("trajectory_online.txt");
      const std::vector<StampedPose> online = outputs.Fresh("trajectory_online.txt")
                                                  ? ReadTumTrajectory(online_path.string())
                                                  : std::vector<StampedPose>{};
      if (online.size() >= 3) {
        const AteResult online_ate = ComputeAte(groundtruth, online);
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
  } else if (dataset.has_groundtruth() && groundtruth.empty()) {
    summary.ate_note = dataset.groundtruth_path() + ": see the warning above";
    std::printf("ATE: not evaluated (%s)\n", summary.ate_note.c_str());
  } else if (!dataset.groundtruth_problem().empty()) {
    summary.ate_note = EchoValue(dataset.groundtruth_problem(), 500);
    std::printf("ATE: not evaluated (%s)\n", summary.ate_note.c_str());
  } else if (groundtruth.empty()) {
    summary.ate_note = "no ground truth";
  } else {
    summary.ate_note = "fewer than 3 frames in the trajectory";
  }
#ifdef DYGSLAM_HAVE_COMPONENTS
  if (outcome.ignored_samples > 0) {
    std::printf("dds: %s\n",
                IgnoredSamplesNote(std::to_string(outcome.ignored_samples) + " samples").c_str());
  }
#endif
  // The exit code, then eval.json (which holds it), then the list of what was written.
  const bool incomplete =
      !outcome.interrupted &&
      ((s.loop_minutes == 0 &&
        (summary.processed + DroppedByRate(summary) < requested || summary.foreign_frames > 0)) ||
       summary.loop_ended_early || !summary.components_cut_short.empty());
  const bool tracking_failure =
      !outcome.interrupted && IsTrackingFailure(outcome.processed, trajectory.size());
  // Frames of another source explain a failed component (the run's player, whose frames the
  // consumers refused): that reason first.
  const bool mixed = incomplete && summary.foreign_frames > 0;
  summary.exit_code = !outputs.failures().empty() ? 1
                      : mixed                     ? kExitIncompleteRun
                      : outcome.exit_code != 0    ? 1
                      : incomplete                ? kExitIncompleteRun
                      : tracking_failure          ? 1
                                                  : 0;
  // A failed component's message is on stderr (its own line); eval.json says that one failed.
  if (summary.exit_code == 1 && summary.error.empty() && summary.component_failed)
    summary.error = "a component of the run failed (its error is on stderr)";
  // An output that could not be written is the run's error (eval.json says why it exits 1).
  for (const auto& [name, reason] : outputs.failures())
    summary.error += (summary.error.empty() ? "" : "; ") + name + " not written: " + reason;
  outputs.Write("eval.json",
                [&] { WriteFileAtomically(outputs.PathOf("eval.json"), RunSummaryJson(summary)); });
  // The files this run wrote; a file an earlier run left (not replaced) is named apart.
  {
    std::string written, stale;
    for (const std::string& name : RunOutputNames()) {
      if (outputs.Fresh(name)) {
        written += (written.empty() ? "" : ",") + std::string(name);
      } else if (fs::exists(outputs.PathOf(name))) {
        stale += (stale.empty() ? "" : ", ") + std::string(name);
      }
    }
    std::printf("outputs: %s/{%s}\n", fs::path(outputs.PathOf("")).parent_path().string().c_str(),
                written.c_str());
    if (!stale.empty())
      std::printf("outputs left from an earlier run, not replaced by this one: %s\n",
                  stale.c_str());
  }
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
                 "dygslam run: error: %s ended before the run did: its part of the outputs "
                 "(map.bt for the mapper, the boxes for the detector) ends there; exit %d\n",
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
                summary.processed, requested, requested - summary.processed);
    std::fprintf(stderr,
                 "dygslam run: error: the run ended with %zu of the %zu requested frames (rgb.txt "
                 "entries %zu to %zu with a depth partner): the stream was cut short (a component "
                 "stopped or stalled, or an end of stream came from outside the run); exit %d\n",
                 summary.processed, requested, s.first, s.last, kExitIncompleteRun);
    return kExitIncompleteRun;
  }
  // A run that tracked (almost) nothing has no trajectory to speak of: fail, and say why.
  if (tracking_failure) {
    PrintTrackingFailure("run", outcome.processed, trajectory.size(), outcome.lost);
    return 1;
  }
  return 0;
}

const CommandRegistrar kRegistrar({"run", "run the SLAM on a dataset folder", RunRun});

}  // namespace
}  // namespace dygslam::cli
