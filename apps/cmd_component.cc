// dygslam component NAME: one DDS component in this process (what `run --processes` starts; also
// by hand, one terminal or host per component). SIGINT / SIGTERM: it flushes and exits 0.
// Compiled only with the DDS components (dygslam_components defines DYGSLAM_HAVE_COMPONENTS).
#ifdef DYGSLAM_HAVE_COMPONENTS
#include "apps/command.h"
#include "components/dds/qos.h"
#include "components/pipeline.h"
#include "core/base/echo.h"
#include "core/base/error.h"
#include "core/dynamic/yolo_detector.h"
#include "run/run_files.h"

namespace dygslam::cli {
namespace {

// The options of `dygslam component`.
void DefineComponentOptions(ArgParser* parser) {
  ArgParser& p = *parser;
  p.AddPositional("NAME", "player | detector | slam | mapper | recorder | pipeline");
  p.AddOption("dataset", "DIR", "dataset folder (player)");
  p.AddOption("config", "FILE", "settings YAML (camera, sensor, modules)");
  p.AddOption("out", "DIR", "output folder (recorder, mapper)", "out/run");
  p.AddOption("filter", "MODE", "none | boxes | geometry | paper | full", "full");
  p.AddOption("frames", "FIRST:LAST", "rgb.txt entries [FIRST, LAST) (player)", "0:");
  p.AddOption("rate", "R", "player: 0 = as fast as consumed, 1 = real time", "0");
  p.AddOption("window", "N", "player: frames in flight (0: none, a camera does not wait)", "2");
  p.AddOption("loop-minutes", "M", "player: replay the frames for M minutes (soak)", "0");
  p.AddOption("detection-wait-ms", "MS", "slam: longest wait for a frame's detections", "1000");
  p.AddOption("detector-model", "NAME", "detector model", "yolo-fastest-1.1");
  p.AddOption("detector-cfg", "FILE", "detector Darknet cfg (overrides --detector-model)");
  p.AddOption("detector-weights", "FILE", "detector weights");
  p.AddOption("detector-names", "FILE", "detector class names");
  AddDdsRunOptions(&p, "none");
  p.AddOption("dds-interface", "ADDR[,ADDR]",
              "this host's IPv4 address(es) for DDS over UDP (default: 127.0.0.1 only)");
  p.AddFlag("no-shm", "no shared-memory transport (all DDS traffic over UDP)");
  p.AddOption("discovery-server", "ADDR:PORT", "discover peers through `dygslam discovery-server`");
  AddMapFileOptions(&p);  // slam: --load-map, --localization, --save-map; mapper: --load-octomap
  p.AddOption("localization-map", "FILE",
              "slam: the same as --load-map FILE --localization (\"\": none; compose)");
  p.AddFlag("progress", "recorder: progress line on stderr");
  p.AddFlag("wait-for-components", "player: wait for the other components' start announcements");
  p.AddFlag("deterministic", "slam waits for every frame's detections; synchronous local mapping");
  p.AddFlag("no-detector", "no detector component (slam runs the System's own detector)");
  p.AddFlag("no-mapper", "no mapper component");
  p.AddFlag("processes", "NAME = pipeline: one process per component (else threads)");
}

// The folders and files of the run (dataset, outputs, settings, maps) into `o`, each checked
// before any DDS work: 0, or the usage error's exit code (UsageError for clashing files).
int ReadComponentFiles(ArgParser& p, const std::string& name, PipelineOptions* out) {
  PipelineOptions& o = *out;
  o.dataset_dir = p.Get("dataset");
  o.output_dir = p.Get("out");
  o.settings_path = p.Get("config");
  CheckComponentRequest(name, o, "e.g. " + ConfigDir() + "/bonn.yaml");
  // The folder the recorder and the mapper write into is checked as run's --out: never a dataset
  // folder, writable, a user's files of the outputs' names kept.
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
  if (!p.Get("localization-map").empty()) {
    if (!o.system.load_map.empty())
      return p.UsageError("--localization-map and --load-map exclude each other");
    o.system.load_map = p.Get("localization-map");
    o.system.localization = true;
  }
  o.save_map = p.Get("save-map");
  o.load_octomap = p.Get("load-octomap");
  RunFiles files{o.dataset_dir,
                 {"--config", o.settings_path},
                 {{"--load-map", p.Get("load-map")},
                  {"--localization-map", p.Get("localization-map")},
                  {"--load-octomap", o.load_octomap}},
                 o.save_map,
                 o.output_dir};
  files.claim_out_dir = false;  // checked above, where the component writes into it
  CheckRunFiles(files, o.system);
  ClaimRunOutputs(files, nullptr);
  return 0;
}

// The detector's model, the numbers, the DDS network and the switches into `o`: 0, or the usage
// error's exit code.
int ReadComponentRun(ArgParser& p, const std::string& name, PipelineOptions* out) {
  PipelineOptions& o = *out;
  if (p.Has("detector-cfg")) {
    o.system.detector.cfg_path = p.Get("detector-cfg");
    o.system.detector.weights_path = p.Get("detector-weights");
    o.system.detector.names_path = p.Get("detector-names");
  }
  o.detector_model = p.Get("detector-model");
  // An unknown --detector-model is an error naming it; the settings' Detector.model, when set, is
  // the model that runs (`dygslam run` passes both, the same).
  if (name == "detector" && p.Has("detector-model") && !p.Has("detector-cfg")) {
    try {
      DetectorOptionsForModel(o.detector_model);
    } catch (const InputError& e) {
      throw InputError(std::string("--detector-model: ") + e.what());
    }
  }
  int64_t wait_ms = 0;
  if (!p.GetNumber("rate", 0, 1e6, &o.rate) ||
      !p.GetInt("window", 0, dds::kFrameHistoryDepth - 1, &o.window) ||
      !p.GetNumber("loop-minutes", 0, 1e6, &o.loop_minutes) ||
      !p.GetInt("detection-wait-ms", 0, 3600000, &wait_ms) ||
      !p.GetInt("domain", -1, 232, &o.domain_id))
    return p.exit_code();
  o.detection_wait = std::chrono::milliseconds(wait_ms);
  o.partition = p.Get("partition");
  o.security_dir = p.Get("security");
  o.network.interfaces = p.GetList("dds-interface");
  o.network.shared_memory = !p.Flag("no-shm");
  o.network.discovery_server = p.Get("discovery-server");
  try {
    o.network.Check();
  } catch (const InvalidOptions& e) {
    return p.UsageError("--dds-interface / --discovery-server: " + EchoValue(e.what(), 400));
  }
  o.run_detector = !p.Flag("no-detector");
  o.run_mapper = !p.Flag("no-mapper");
  o.progress = p.Flag("progress");
  o.wait_for_components = p.Flag("wait-for-components");
  o.processes = p.Flag("processes");
  return 0;
}

int RunComponentCommand(const std::vector<std::string>& args) {
  ArgParser p("component",
              "NAME --dataset DIR --config FILE [--out DIR] [--filter MODE] [--frames FIRST:LAST] "
              "[--deterministic] [--domain N] ...",
              "Runs one pipeline component (player | detector | slam | mapper | recorder) as its "
              "own\nprocess over Fast DDS (the transport benchmark is its own tool: "
              "dygslam_bench_transport).");
  DefineComponentOptions(&p);
  p.AllowEmptyValues();
  if (!p.Parse(args)) return p.exit_code();
  if (!CheckFilterOption(&p)) return 2;
  // Everything the command line can get wrong is a usage error (exit 2) naming the option as the
  // user types it, found before any DDS participant exists.
  const std::string name = p.Positional("NAME");
  PipelineOptions o;
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
