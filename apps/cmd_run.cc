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
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>

#include "apps/command.h"
#include "core/base/echo.h"
#include "core/base/error.h"
#include "core/config/settings.h"
#include "core/dynamic/yolo_detector.h"
#include "core/io/dataset.h"
#include "core/io/detections_io.h"
#include "core/io/file_util.h"
#include "core/io/trajectory_io.h"
#include "core/system/system.h"
#include "mapping/octomap_builder.h"
#include "run/run_controller.h"
#include "run/run_settings.h"
#ifdef DYGSLAM_HAVE_COMPONENTS
#include "components/pipeline.h"
#include "components/protocol.h"
#endif

namespace dygslam::cli {
namespace {
namespace fs = std::filesystem;

// --rate above 0: the slowest replay that is still a replay (0.01x = a 30 Hz frame every 3.3 s).
constexpr double kMinRate = 0.01;

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
void WarnUnmatchedDetections(const std::string& path, const RunControllerOptions& s,
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

// The DDS pipeline of `dygslam run` (components/pipeline.h) for the run controller.
PipelineRunResult RunThroughPipeline(const RunControllerOptions& s) {
  PipelineOptions o;
  o.dataset_dir = s.dataset_dir;
  o.output_dir = s.out.string();
  o.settings_path = s.settings_path;
  o.system = s.system;
  o.octomap = s.octomap;
  o.first_entry = s.first;
  o.last_entry = s.last;
  o.processes = s.mode == RunMode::kPipelineProcesses;
  o.run_mapper = s.map;
  o.domain_id = s.domain_id;
  o.partition = s.partition.empty() ? RunPartition() : s.partition;
  o.security_dir = s.security_dir;
  std::fprintf(stderr, "[run] DDS partition '%s' (a bridge joins with --partition %s)\n",
               EchoValue(o.partition).c_str(), EchoValue(o.partition).c_str());
  o.progress = s.progress;
  o.loop_minutes = s.loop_minutes;
  o.rate = s.rate;
  if (s.rate > 0) o.window = 0;  // a camera does not wait for the pipeline
  o.save_map = s.save_map;
  o.load_octomap = s.load_octomap;
  StopReport report;
  PipelineRunResult result;
  result.exit_code = RunPipeline(o, &report);
  result.interrupted = report.signaled;
  result.ignored_samples = report.ignored_samples;
  if (report.ignored_samples > 0)
    result.ignored_samples_note =
        IgnoredSamplesNote(std::to_string(report.ignored_samples) + " samples");
  result.components_cut_short = report.components_cut_short;
  return result;
}
#endif

// The options of `dygslam run` (`security_env`: the default of --security).
void DefineRunOptions(ArgParser* parser, const char* security_env) {
  ArgParser& p = *parser;
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
}

// The mode options checked against each other before any work: 0, or the usage error's exit code.
int CheckModeOptions(ArgParser& p, const char* security_env) {
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
  return 0;
}

// The settings, the files the options name (each checked before any work) and the numbers of the
// command line into `s`: 0, or the usage error's exit code.
int ReadRunInputs(ArgParser& p, const fs::path& out_dir, RunControllerOptions* s) {
  s->dataset_dir = p.Positional("DATASET_DIR");
  s->settings_path =
      p.Has("config") ? p.Get("config") : DefaultSettingsPath(s->dataset_dir, ConfigDir());
  s->filter = p.Get("filter");
  {
    const RunConfiguration c =
        LoadRunConfiguration({s->settings_path, CliSettingsReadOptions(p.Flag("strict-settings")),
                              p.Get("filter"), p.Flag("deterministic")});
    s->system = c.system;
    s->octomap = c.octomap;
  }
  ::setenv("DYGSLAM_SETTINGS_WARNED", "1", 1);  // --processes: components do not repeat them
  // No output may replace an input or another output: checked before any work (exit 2).
  if (const std::string clash = FindDatasetRunOutputClash(
          DatasetRunInputs(p, p.Positional("DATASET_DIR"),
                           p.Has("config") ? "--config" : "the settings file", s->settings_path,
                           s->system, {"load-map", "load-octomap", "detections"}),
          p, out_dir);
      !clash.empty())
    return p.UsageError(clash);
  s->map = !p.Flag("no-map");
  if (p.Flag("localization") && !p.Has("load-map"))
    return p.UsageError("--localization needs --load-map FILE");
  if (p.Has("save-map")) {
    s->save_map = p.Get("save-map");
    CheckMapFileWritable(s->save_map);
  }
  if (p.Has("load-octomap")) {
    if (!s->map) return p.UsageError("--load-octomap and --no-map exclude each other");
    s->load_octomap = p.Get("load-octomap");
    try {  // checked before any work (InputError naming the option and the file)
      ReadOctoMap(s->load_octomap);
    } catch (const InputError& e) {
      throw InputError(std::string("--load-octomap: ") + e.what());
    }
  }
  if (p.Has("load-map")) {
    // Checked before any work: a bad map is an error naming the file, no output is written.
    s->system.load_map = p.Get("load-map");
    s->system.localization = p.Flag("localization");
    std::printf("map file: loaded %s (%s)%s\n", s->system.load_map.c_str(),
                DescribeMapFile(CheckMapFile(s->system.load_map, s->system)).c_str(),
                s->system.localization ? ", localization mode" : "");
  }
  if (p.Has("detections")) {
    if (p.Flag("processes")) return p.UsageError("--detections works with --direct only");
    // Class ids are checked against the detector's classes (its names file) when it is found.
    DetectorOptions names_of = s->system.detector;
    if (names_of.names_path.empty()) {
      try {
        names_of = DetectorOptionsForModel("yolo-fastest-1.1");
      } catch (const InputError&) {  // no models here: class ids are not checked
      }
    }
    const int num_classes = CountClassNames(names_of.names_path);
    s->detections = ReadDetections(p.Get("detections"), num_classes, names_of.names_path);
    s->use_detection_file = true;
  }
  s->progress = !p.Flag("quiet");
  if (!p.GetNumber("rate", 0, 1000, &s->rate) ||
      !p.GetNumber("loop-minutes", 0, 1e6, &s->loop_minutes) ||
      !p.GetInt("domain", -1, 232, &s->domain_id))
    return p.exit_code();
  // Below 0.01x a 30 Hz sequence waits more than 3 s per frame: a mistyped rate, not a replay.
  if (s->rate > 0 && s->rate < kMinRate) {
    return p.UsageError("--rate " + p.Get("rate") +
                        ": must be 0 (as fast as the pipeline takes "
                        "the frames) or between 0.01 and 1000");
  }
  if (s->loop_minutes > 0 && p.Flag("direct"))
    return p.UsageError("--loop-minutes works with the DDS modes only (not --direct)");
  if (s->loop_minutes > 0 && s->use_detection_file)
    return p.UsageError("--loop-minutes works with the DDS modes only (--detections runs direct)");
  return 0;
}

// The checks that need the dataset's lists (no output onto its images, the --frames range): 0, or
// the usage error's exit code; the range into `s`.
int CheckRunDataset(ArgParser& p, const RgbdDataset& dataset, const fs::path& out_dir,
                    RunControllerOptions* s) {
  // Nor a dataset image (a --save-map onto rgb/….png would destroy it): checked once the lists
  // are read, before any work (exit 2).
  if (const std::string clash =
          FindOutputOnDatasetImage(dataset, s->dataset_dir, DatasetRunOutputs(p, out_dir));
      !clash.empty())
    return p.UsageError(clash);
  if (const std::string foreign = FindForeignFileAtSaveMap(p); !foreign.empty())
    return p.UsageError(foreign);
  // The folder the map goes into is the one there now, even if it is replaced while the run goes.
  if (p.Has("save-map")) PinFolderOfOutput(p.Get("save-map"));
  if (const std::string foreign = FindForeignFileInRunOutputs(out_dir); !foreign.empty())
    return p.UsageError(foreign);
  s->first = 0;
  s->last = dataset.num_rgb_entries();
  std::string frames_note;  // --frames beyond the dataset: cut, with a warning
  if (p.Has("frames")) {
    try {  // a malformed or out-of-range --frames is a usage error (exit 2), as other numbers
      std::tie(s->first, s->last) =
          ParseFrameRange(p.Get("frames"), dataset.num_rgb_entries(), &frames_note);
    } catch (const std::exception& e) {
      return p.UsageError(e.what());
    }
  }
  if (!frames_note.empty()) std::fprintf(stderr, "dygslam run: warning: %s\n", frames_note.c_str());
  return 0;
}

// The dataset's ground truth, or none (a warning says why): it only scores the run.
std::vector<StampedPose> ReadRunGroundTruth(const RgbdDataset& dataset) {
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
  return groundtruth;
}

// The run's mode from the flags (and the build), and the pipeline runner of the DDS modes.
PipelineRunner SelectMode(const ArgParser& p, RunControllerOptions* s) {
  s->mode = p.Flag("processes") ? RunMode::kPipelineProcesses : RunMode::kPipeline;
  if (p.Flag("direct") || s->use_detection_file) s->mode = RunMode::kDirect;
  PipelineRunner pipeline;
#ifdef DYGSLAM_HAVE_COMPONENTS
  pipeline = RunThroughPipeline;
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
  s->mode = RunMode::kDirect;
#endif
  return pipeline;
}

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
  const char* security_env = std::getenv("DYGSLAM_DDS_SECURITY_DIR");
  DefineRunOptions(&p, security_env);
  if (!p.Parse(args)) return p.exit_code();
  if (const int code = CheckModeOptions(p, security_env); code != 0) return code;
  if (p.Flag("strict-settings")) ::setenv("DYGSLAM_STRICT_SETTINGS", "1", 1);  // --processes
  // The output folder first: a bad --out is found before the run, not after it.
  const fs::path out_dir = PrepareOutputDir("out", p.Get("out"));
  RunControllerOptions s;
  if (const int code = ReadRunInputs(p, out_dir, &s); code != 0) return code;
  DatasetOptions dataset_options;
  dataset_options.refuse_outside_paths = p.Flag("strict-paths");
  const RgbdDataset dataset = RgbdDataset::Open(s.dataset_dir, dataset_options);
  if (const int code = CheckRunDataset(p, dataset, out_dir, &s); code != 0) return code;
  std::vector<StampedPose> groundtruth = ReadRunGroundTruth(dataset);
  if (s.use_detection_file) WarnUnmatchedDetections(p.Get("detections"), s, dataset);
  WarnAboutDataset("run", dataset, s.first, s.last, s.system.sensor.depth_map_factor,
                   s.system.camera.width, s.system.camera.height,
                   groundtruth.empty() ? nullptr : &groundtruth);
  s.out = out_dir;
  s.partition = p.Get("partition");
  s.security_dir = p.Get("security");
  const PipelineRunner pipeline = SelectMode(p, &s);
  // The detector's model files before any output or component: missing models fail here, nothing
  // written (a detector component failing on them before it announced itself would leave a
  // deterministic slam waiting for boxes).
  if (!s.use_detection_file) ResolveDetectorModel(&s.system);

  // This run's outputs: written atomically, nothing deleted up front (see RunOutputs).
  RunController controller(s, dataset, std::move(groundtruth), pipeline);
  if (controller.without_depth_partner() > 0) {
    // Said before the run, not only counted in the summary: a depth.txt cut short or with a gap
    // leaves frames out without any other sign.
    std::fprintf(stderr,
                 "dygslam run: warning: %zu of the %zu rgb.txt entries %zu to %zu have no depth "
                 "image to pair with (depth.txt / associations): they are left out, %zu frames "
                 "requested\n",
                 controller.without_depth_partner(), s.last - s.first, s.first, s.last,
                 controller.requested());
  }
  return controller.Run();
}

const CommandRegistrar kRegistrar({"run", "run the SLAM on a dataset folder", RunRun});

}  // namespace
}  // namespace dygslam::cli
