// dygslam component NAME: one DDS component in this process (what `run --processes` starts; also
// by hand, one terminal or host per component). SIGINT / SIGTERM: it flushes and exits 0.
// Compiled only with the DDS components (dygslam_components defines DYGSLAM_HAVE_COMPONENTS).
#ifdef DYGSLAM_HAVE_COMPONENTS
#include "apps/command.h"
#include "components/dds/qos.h"
#include "components/pipeline.h"
#include "core/base/echo.h"
#include "core/base/error.h"
#include "run/run_files.h"

namespace dygslam::cli {
namespace {

// The options of `dygslam component`; those bound to a field of `o` are read by ReadBound().
void DefineComponentOptions(ArgParser* parser, PipelineOptions* o) {
  ArgParser& p = *parser;
  p.AddPositional("NAME", "player | detector | slam | mapper | recorder | pipeline");
  p.AddOption("dataset", "DIR", "dataset folder (player)");
  p.AddOption("config", "FILE", "settings YAML (camera, sensor, modules)");
  p.AddOption("out", "DIR", "output folder (recorder, mapper)", "out/run");
  p.AddOption("filter", "MODE", "none | boxes | geometry | paper | full", "full");
  p.AddOption("frames", "FIRST:LAST", "rgb.txt entries [FIRST, LAST) (player)", "0:");
  p.Bind("rate", "R", "player: 0 = as fast as consumed, 1 = real time", &o->rate, 0, 1e6);
  p.Bind("window", "N", "player: frames in flight (0: none, a camera does not wait)", &o->window, 0,
         dds::kFrameHistoryDepth - 1);
  p.Bind("loop-minutes", "M", "player: replay the frames for M minutes (soak)", &o->loop_minutes, 0,
         1e6);
  p.AddOption("detection-wait-ms", "MS", "slam: longest wait for a frame's detections", "1000");
  p.Bind("detector-model", "NAME", "detector model", &o->detector_model);
  p.AddOption("detector-cfg", "FILE", "detector Darknet cfg (overrides --detector-model)");
  p.AddOption("detector-weights", "FILE", "detector weights");
  p.AddOption("detector-names", "FILE", "detector class names");
  AddDdsRunOptions(&p, "none");
  p.AddOption("dds-interface", "ADDR[,ADDR]",
              "this host's IPv4 address(es) for DDS over UDP (default: 127.0.0.1 only)");
  p.BindFlag("no-shm", "no shared-memory transport (all DDS traffic over UDP)",
             &o->network.shared_memory, false);
  p.Bind("discovery-server", "ADDR:PORT", "discover peers through `dygslam discovery-server`",
         &o->network.discovery_server);
  AddMapFileOptions(&p);  // slam: --load-map, --localization, --save-map; mapper: --load-octomap
  p.AddOption("localization-map", "FILE",
              "slam: the same as --load-map FILE --localization (\"\": none; compose)");
  p.BindFlag("progress", "recorder: progress line on stderr", &o->progress);
  p.BindFlag("wait-for-components", "player: wait for the other components' start announcements",
             &o->wait_for_components);
  p.AddFlag("deterministic", "slam waits for every frame's detections; synchronous local mapping");
  p.BindFlag("no-detector", "no detector component (slam runs the System's own detector)",
             &o->run_detector, false);
  p.BindFlag("no-mapper", "no mapper component", &o->run_mapper, false);
  p.BindFlag("processes", "NAME = pipeline: one process per component (else threads)",
             &o->processes);
}

// The folders and files of the run (dataset, outputs, settings, maps) into `o`, each checked
// before any DDS work: 0, or the usage error's exit code (UsageError for clashing files).
int ReadComponentFiles(ArgParser& p, const std::string& name, PipelineOptions* out) {
  PipelineOptions& o = *out;
  o.dataset_dir = p.Get("dataset");
  o.output_dir = p.Get("out");
  o.settings_path = p.Get("config");
  CheckComponentRequest(name, o, "e.g. " + ConfigDir() + "/bonn.yaml");
  // The recorder's and the mapper's folder is checked as run's --out (writable, a user's files
  // kept).
  if (name == "recorder" || name == "mapper" || name == "pipeline") {
    PrepareOutputDir("out", o.output_dir,
                     name == "recorder" ? FolderOutputs::kTrajectories
                     : name == "mapper" ? FolderOutputs::kMap
                                        : FolderOutputs::kAll);
    if (const std::string foreign = FindForeignFileInRunOutputs(o.output_dir); !foreign.empty())
      return p.UsageError(foreign);
  }
  if (o.dataset_dir.empty()) o.dataset_dir = "-";  // only the player reads it
  if (!CheckPartitionOption(&p)) return 2;
  if (!p.GetOpenFrameRange("frames", &o.first_entry, &o.last_entry)) return p.exit_code();
  const RunConfiguration c = LoadCommandSettings(p, o.settings_path);
  o.system = c.system;
  o.octomap = c.octomap;
  o.system.load_map = p.Get("load-map");
  o.system.localization = p.Flag("localization");
  if (o.system.localization && p.Get("load-map").empty())
    return p.UsageError("--localization needs --load-map FILE (the map to localize in)");
  if (const std::string map = p.Get("localization-map"); !map.empty()) {
    if (!o.system.load_map.empty())
      return p.UsageError("--localization-map and --load-map exclude each other");
    o.system.load_map = map;
    o.system.localization = true;
  }
  o.save_map = p.Get("save-map");
  o.load_octomap = p.Get("load-octomap");
  RunFiles files{o.dataset_dir, {"--config", o.settings_path}, {}, o.save_map, o.output_dir};
  for (const char* option : {"load-map", "localization-map", "load-octomap"})
    files.given.push_back({std::string("--") + option, p.Get(option)});
  files.claim_out_dir = false;  // checked above, where the component writes into it
  CheckRunFiles(files, o.system);
  ClaimRunOutputs(files, nullptr);
  return 0;
}

// The detector's model, the numbers, the DDS network and the switches into `o`: 0, or the usage
// error's exit code.
int ReadComponentRun(ArgParser& p, const std::string& name, PipelineOptions* out) {
  PipelineOptions& o = *out;
  int64_t wait_ms = 0;
  if (!p.ReadBound() || !p.GetInt("detection-wait-ms", 0, 3600000, &wait_ms) ||
      !p.GetInt("domain", -1, 232, &o.domain_id))
    return p.exit_code();
  if (p.Has("detector-cfg")) {
    o.system.detector.cfg_path = p.Get("detector-cfg");
    o.system.detector.weights_path = p.Get("detector-weights");
    o.system.detector.names_path = p.Get("detector-names");
  }
  // The settings' Detector.model, when set, is the model that runs (`run` passes both, the same).
  if (name == "detector" && p.Has("detector-model") && !p.Has("detector-cfg"))
    CheckDetectorModelOption(o.detector_model);
  o.detection_wait = std::chrono::milliseconds(wait_ms);
  o.partition = p.Get("partition");
  o.security_dir = p.Get("security");
  o.network.interfaces = p.GetList("dds-interface");
  try {
    o.network.Check();
  } catch (const InvalidOptions& e) {
    return p.UsageError("--dds-interface / --discovery-server: " + EchoValue(e.what(), 400));
  }
  return 0;
}

int RunComponentCommand(const std::vector<std::string>& args) {
  ArgParser p("component", "NAME --dataset DIR --config FILE [--out DIR] [--frames FIRST:LAST] ...",
              "Runs one pipeline component (player | detector | slam | mapper | recorder) as its "
              "own\nprocess over Fast DDS.");
  PipelineOptions o;
  DefineComponentOptions(&p, &o);
  p.AllowEmptyValues();
  if (!p.Parse(args)) return p.exit_code();
  if (!CheckFilterOption(&p)) return 2;
  // What the command line gets wrong is a usage error (exit 2) before any DDS participant exists.
  const std::string name = p.Positional("NAME");
  if (const int code = ReadComponentFiles(p, name, &o); code != 0) return code;
  if (const int code = ReadComponentRun(p, name, &o); code != 0) return code;
  if (name == "pipeline") return RunPipeline(o);  // the whole pipeline
  return RunComponent(name, o, std::make_shared<StopFlag>(StopFlag::Signals::kStop));
}

const CommandRegistrar kRegistrar({"component", "(internal) run one DDS pipeline component",
                                   RunComponentCommand});

}  // namespace
}  // namespace dygslam::cli
#endif  // DYGSLAM_HAVE_COMPONENTS
