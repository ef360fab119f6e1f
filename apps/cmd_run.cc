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
#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include "apps/command.h"
#include "core/base/echo.h"
#include "core/base/error.h"
#include "core/io/dataset.h"
#include "run/run_controller.h"
#include "run/run_inputs.h"
#include "run/run_settings.h"
#ifdef DYGSLAM_HAVE_COMPONENTS
#include "components/run_pipeline.h"
#endif

namespace dygslam::cli {
namespace {
namespace fs = std::filesystem;

// --rate above 0: the slowest replay that is still a replay (0.01x = a 30 Hz frame every 3.3 s).
constexpr double kMinRate = 0.01;

// The options of `dygslam run` (`security_env`: the default of --security).
void DefineRunOptions(ArgParser* parser, const char* security_env) {
  ArgParser& p = *parser;
  p.AddPositional("DATASET_DIR", "folder with rgb.txt, depth.txt (groundtruth.txt optional)");
  p.AddOption("config", "FILE",
              "settings YAML (ORB-SLAM2 keys); default: DATASET_DIR/camera.yaml or a preset");
  p.AddOption("filter", "MODE", "dynamic filter: none | boxes | geometry | paper | full", "full");
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
  if (!CheckPartitionOption(&p)) return 2;
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
    CheckOctoMapToContinue("--load-octomap", s->load_octomap);
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
    s->detections = ReadRunDetections(p.Get("detections"), s->system);
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
  if (!p.GetFrameRange("frames", dataset.num_rgb_entries(), &s->first, &s->last))
    return p.exit_code();
  return 0;
}

// The run's mode from the flags (and the build), and the pipeline runner of the DDS modes.
PipelineRunner SelectMode(const ArgParser& p, RunControllerOptions* s) {
  s->mode = p.Flag("processes") ? RunMode::kPipelineProcesses : RunMode::kPipeline;
  if (p.Flag("direct") || s->use_detection_file) s->mode = RunMode::kDirect;
  PipelineRunner pipeline;
#ifdef DYGSLAM_HAVE_COMPONENTS
  pipeline = RunControllerPipeline;
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
  ArgParser p("run", R"(DATASET_DIR [--config FILE] [--filter none|boxes|geometry|paper|full] [--frames FIRST:LAST] [--out DIR] [--deterministic] [--processes | --direct] [--no-map])",
              R"(Runs the SLAM on a TUM/Bonn dataset folder; writes DIR/trajectory.txt (TUM format, every tracked
frame), DIR/keyframes.txt, DIR/frames.csv (state and stage times per frame) and DIR/map.bt
(OctoMap of the static scene). Default: the DDS components (player, detector, slam, mapper,
recorder) on threads of this process; --processes: one process per component; --direct: no
DDS, the library loop. SIGINT / SIGTERM: outputs are flushed, exit 0.)");
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
  if (s.use_detection_file)
    WarnUnmatchedDetections(p.Get("detections"), s.detections, s.system.camera, dataset, s.first,
                            s.last);
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
  return RunController(s, dataset, std::move(groundtruth), pipeline).Run();
}

const CommandRegistrar kRegistrar({"run", "run the SLAM on a dataset folder", RunRun});

}  // namespace
}  // namespace dygslam::cli
