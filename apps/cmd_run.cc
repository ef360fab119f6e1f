// dygslam run: the SLAM on a dataset folder (run/run_controller.h) in one of three modes with the
// same outputs and summary: the DDS pipeline on threads of this process (default), one process
// per component (--processes), or no DDS (--direct). SIGINT / SIGTERM: outputs written, exit 0.
#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include "apps/command.h"
#include "core/base/echo.h"
#include "core/base/error.h"
#include "core/io/dataset.h"
#include "run/run_controller.h"
#include "run/run_files.h"
#include "run/run_inputs.h"
#include "run/run_settings.h"
#ifdef DYGSLAM_HAVE_COMPONENTS
#include "components/run_pipeline.h"
#endif

namespace dygslam::cli {
namespace {
// The options of `dygslam run`.
void DefineRunOptions(ArgParser* parser) {
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
  AddDdsRunOptions(&p, "unique per run");
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
  AddMapFileOptions(&p);
}

// The numbers and the mode options, checked before any work, into `s`: 0, or the usage error's
// exit code (throws UsageError for options that exclude each other).
int CheckModeOptions(ArgParser& p, RunControllerOptions* s) {
  if (!CheckFilterOption(&p) || !CheckPartitionOption(&p)) return 2;
  if (!p.GetNumber("rate", 0, 1000, &s->rate) ||
      !p.GetNumber("loop-minutes", 0, 1e6, &s->loop_minutes) ||
      !p.GetInt("domain", -1, 232, &s->domain_id))
    return p.exit_code();
  // Below 0.01x a 30 Hz sequence waits more than 3 s per frame: a mistyped rate, not a replay.
  if (s->rate > 0 && s->rate < 0.01)
    return p.UsageError("--rate " + p.Get("rate") +
                        ": must be 0 (as fast as the pipeline takes "
                        "the frames) or between 0.01 and 1000");
  s->mode = ChooseRunMode({p.Flag("direct"), p.Flag("processes"), p.Has("detections"),
                           p.Has("security"), s->loop_minutes > 0});
  const char* security_env = std::getenv("DYGSLAM_DDS_SECURITY_DIR");
  if (!p.Has("security") && security_env != nullptr && *security_env != '\0' &&
      s->mode == RunMode::kDirect)
    std::fprintf(stderr,
                 "dygslam run: warning: DYGSLAM_DDS_SECURITY_DIR is set but --direct uses no DDS "
                 "(nothing to secure)\n");
  return 0;
}

// The settings and the files the options name, each checked before any work, into `s`. Throws
// UsageError (clashing files), InputError (a file that cannot be used).
void ReadRunInputs(ArgParser& p, const std::filesystem::path& out_dir, RunControllerOptions* s,
                   RunFiles* files) {
  s->dataset_dir = p.Positional("DATASET_DIR");
  s->settings_path =
      p.Has("config") ? p.Get("config") : DefaultSettingsPath(s->dataset_dir, ConfigDir());
  s->filter = p.Get("filter");
  const RunConfiguration c = LoadCommandSettings(p, s->settings_path);
  s->system = c.system;
  s->octomap = c.octomap;
  ::setenv("DYGSLAM_SETTINGS_WARNED", "1", 1);  // --processes: components do not repeat them
  *files = {s->dataset_dir,
            {p.Has("config") ? "--config" : "the settings file", s->settings_path},
            {{"--load-map", p.Get("load-map")},
             {"--load-octomap", p.Get("load-octomap")},
             {"--detections", p.Get("detections")}},
            p.Get("save-map"),
            out_dir};
  CheckRunFiles(*files, s->system);  // no output replaces an input or another output
  s->map = !p.Flag("no-map");
  ReadRunInputFiles({p.Get("load-map"), p.Flag("localization"), p.Get("save-map"),
                     p.Get("load-octomap"), p.Get("detections")},
                    s);
  s->progress = !p.Flag("quiet");
}

int RunRun(const std::vector<std::string>& args) {
  ArgParser p(
      "run",
      R"(DATASET_DIR [--config FILE] [--filter none|boxes|geometry|paper|full] [--frames FIRST:LAST] [--out DIR] [--deterministic] [--processes | --direct] [--no-map])",
      R"(Runs the SLAM on a TUM/Bonn dataset folder; writes DIR/trajectory.txt (TUM format, every tracked
frame), DIR/keyframes.txt, DIR/frames.csv (state and stage times per frame) and DIR/map.bt
(OctoMap of the static scene). Default: the DDS components (player, detector, slam, mapper,
recorder) on threads of this process; --processes: one process per component; --direct: no
DDS, the library loop. SIGINT / SIGTERM: outputs are flushed, exit 0.)");
  DefineRunOptions(&p);
  if (!p.Parse(args)) return p.exit_code();
  RunControllerOptions s;
  if (const int code = CheckModeOptions(p, &s); code != 0) return code;
  if (p.Flag("strict-settings")) ::setenv("DYGSLAM_STRICT_SETTINGS", "1", 1);  // --processes
  // The output folder first: a bad --out is found before the run, not after it.
  const std::filesystem::path out_dir = PrepareOutputDir("out", p.Get("out"));
  RunFiles files;
  ReadRunInputs(p, out_dir, &s, &files);
  DatasetOptions dataset_options;
  dataset_options.refuse_outside_paths = p.Flag("strict-paths");
  const RgbdDataset dataset = RgbdDataset::Open(s.dataset_dir, dataset_options);
  ClaimRunOutputs(files, &dataset);  // nor onto a dataset image or a user's file
  if (!p.GetFrameRange("frames", dataset.num_rgb_entries(), &s.first, &s.last))
    return p.exit_code();
  std::vector<StampedPose> groundtruth =
      ReadGroundTruthAndWarn("run", s, dataset, p.Get("detections"));
  s.out = out_dir;
  s.partition = p.Get("partition");
  s.security_dir = p.Get("security");
  PipelineRunner pipeline;  // none in a build without DDS: the run goes direct
#ifdef DYGSLAM_HAVE_COMPONENTS
  pipeline = RunControllerPipeline;
#endif
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
