// Hidden subcommand: dygslam component <player|detector|slam|mapper|recorder|pipeline> ...
// Runs one DDS component in this process (what `RunPipeline` with processes = true spawns; also
// usable by hand, one terminal per component, e.g. to run the mapper on another machine with
// FASTRTPS_DEFAULT_PROFILES_FILE). SIGINT / SIGTERM: the component flushes and exits 0.
// Compiled only when the DDS components are built (dygslam_components defines
// DYGSLAM_HAVE_COMPONENTS for its users).
#ifdef DYGSLAM_HAVE_COMPONENTS
#include <algorithm>
#include <cstdlib>
#include <iostream>
#include <iterator>
#include <sstream>

#include "apps/command.h"
#include "components/dds/qos.h"
#include "components/pipeline.h"
#include "core/base/echo.h"
#include "core/base/error.h"
#include "core/config/settings.h"
#include "core/dynamic/yolo_detector.h"
#include "core/io/dataset.h"
#include "run/run_settings.h"

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
  p.AddOption(
      "window", "N",
      "player back-pressure window in frames (0: none, a camera does not wait: with --rate)", "2");
  p.AddOption("loop-minutes", "M", "player: replay the frames for M minutes (soak)", "0");
  p.AddOption("detection-wait-ms", "MS", "slam: longest wait for a frame's detections", "1000");
  p.AddOption("detector-model", "NAME", "detector model (DetectorOptionsForModel)",
              "yolo-fastest-1.1");
  p.AddOption("detector-cfg", "FILE", "detector Darknet cfg (overrides --detector-model)");
  p.AddOption("detector-weights", "FILE", "detector weights");
  p.AddOption("detector-names", "FILE", "detector class names");
  p.AddOption("domain", "N", "DDS domain id (default DYGSLAM_DOMAIN_ID or 0)", "-1");
  p.AddOption("partition", "NAME", "DDS partition of every reader / writer (default: none)");
  const char* security_env = std::getenv("DYGSLAM_DDS_SECURITY_DIR");
  p.AddOption("security", "DIR",
              "DDS Security credentials: an identity folder, or make_dds_certs.sh's OUT_DIR with "
              "one folder per component (default: $DYGSLAM_DDS_SECURITY_DIR; none = off)",
              security_env != nullptr ? security_env : "");
  p.AddOption("dds-interface", "ADDR[,ADDR]",
              "IPv4 address(es) of this host's interfaces for DDS over UDP, to run components on "
              "several hosts (default: 127.0.0.1 only)");
  p.AddFlag("no-shm", "no shared-memory transport (all DDS traffic over UDP)");
  p.AddOption("discovery-server", "ADDR:PORT",
              "discover peers through a discovery server (`dygslam discovery-server`) instead of "
              "multicast");
  p.AddOption("load-map", "FILE", "slam: start from this SLAM map file");
  p.AddFlag("localization", "slam: with --load-map, track without adding keyframes or points");
  p.AddOption("localization-map", "FILE",
              "slam: the same as --load-map FILE --localization (\"\": none; compose)");
  p.AddOption("save-map", "FILE", "slam: write the SLAM map file at the end (also on stop)");
  p.AddOption("load-octomap", "FILE", "mapper: continue this OctoMap (.ot)");
  p.AddFlag("progress", "recorder: progress line on stderr");
  p.AddFlag("wait-for-components", "player: wait for the other components' start announcements");
  p.AddFlag("deterministic", "slam waits for every frame's detections; synchronous local mapping");
  p.AddFlag("no-detector", "no detector component (slam runs the System's own detector)");
  p.AddFlag("no-mapper", "no mapper component");
  p.AddFlag("processes", "NAME = pipeline: one process per component (else threads)");
}

// The folders and files of the run (dataset, outputs, settings, frame range) into `o`: 0, or the
// usage error's exit code.
int ReadComponentFiles(ArgParser& p, const std::string& name, PipelineOptions* out) {
  PipelineOptions& o = *out;
  o.dataset_dir = p.Get("dataset");
  o.output_dir = p.Get("out");
  o.settings_path = p.Get("config");
  if (o.settings_path.empty())
    return p.UsageError("--config FILE is required: the settings YAML of the run (e.g. " +
                        ConfigDir() + "/bonn.yaml)");
  if (o.dataset_dir.empty() && (name == "player" || name == "pipeline"))
    return p.UsageError("the " + name +
                        " needs --dataset DIR: the dataset folder that holds rgb.txt and "
                        "depth.txt (e.g. --dataset data/bonn_crowd_part)");
  if (o.output_dir.empty()) return p.UsageError("--out: empty folder name");
  // The folder the recorder and the mapper write into, checked as run's --out before any DDS
  // work: never a dataset folder, writable.
  if (name == "recorder" || name == "mapper" || name == "pipeline") {
    PrepareOutputDir("out", o.output_dir,
                     name == "recorder" ? FolderOutputs::kTrajectories
                     : name == "mapper" ? FolderOutputs::kMap
                                        : FolderOutputs::kAll);
    // An earlier run's outputs are replaced, never a user's files of the same names.
    if (const std::string foreign = FindForeignFileInRunOutputs(o.output_dir); !foreign.empty())
      return p.UsageError(foreign);
  }
  if (o.dataset_dir.empty()) o.dataset_dir = "-";  // only the player reads it
  if (!CheckPartitionOption(&p)) return 2;
  try {
    const FrameRangeText range = SplitFrameRange(p.Get("frames"));  // 0 = all
    o.first_entry = range.first.value_or(0);
    o.last_entry = range.last.value_or(0);
  } catch (const InvalidOptions& e) {
    return p.UsageError(e.what());
  }
  if (o.last_entry != 0 && o.last_entry <= o.first_entry)
    return p.UsageError("--frames '" + EchoValue(p.Get("frames")) +
                        "': empty range (LAST must be above FIRST)");
  {
    const RunConfiguration c = LoadRunConfiguration(
        {o.settings_path, CliSettingsReadOptions(false), p.Get("filter"), p.Flag("deterministic")});
    o.system = c.system;
    o.octomap = c.octomap;
  }
  return 0;
}

// The maps (SLAM map to load or save, OctoMap to continue) and the detector's model into `o`: 0,
// or the usage error's exit code.
int ReadComponentMapsAndModel(ArgParser& p, const std::string& name, PipelineOptions* out) {
  PipelineOptions& o = *out;
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
  // No output may replace an input or another output (a --save-map onto its --config).
  if (const std::string clash = FindDatasetRunOutputClash(
          DatasetRunInputs(p, o.dataset_dir, "--config", o.settings_path, o.system,
                           {"load-map", "localization-map", "load-octomap"}),
          p, o.output_dir);
      !clash.empty())
    return p.UsageError(clash);
  if (const std::string foreign = FindForeignFileAtSaveMap(p); !foreign.empty())
    return p.UsageError(foreign);
  // The folder the map goes into is the one there now, even if it is replaced while the run goes.
  if (p.Has("save-map")) PinFolderOfOutput(p.Get("save-map"));
  o.load_octomap = p.Get("load-octomap");
  if (p.Has("detector-cfg")) {
    o.system.detector.cfg_path = p.Get("detector-cfg");
    o.system.detector.weights_path = p.Get("detector-weights");
    o.system.detector.names_path = p.Get("detector-names");
  }
  o.detector_model = p.Get("detector-model");
  // The detector: an unknown --detector-model is an error naming it (before, with a settings file
  // it was silently ignored, a bogus name included). The settings' Detector.model, when set,
  // is the model that runs (`dygslam run` passes both, the same).
  if (name == "detector" && p.Has("detector-model") && !p.Has("detector-cfg")) {
    try {
      DetectorOptionsForModel(o.detector_model);
    } catch (const InputError& e) {
      throw InputError(std::string("--detector-model: ") + e.what());
    }
  }
  return 0;
}

// The numbers, the DDS network and the switches into `o`: 0, or the usage error's exit code.
int ReadComponentTransport(ArgParser& p, PipelineOptions* out) {
  PipelineOptions& o = *out;
  // Bad numbers are usage errors naming the option (exit 2), as on `dygslam run`.
  int64_t window = 0, wait_ms = 0, domain = 0;
  if (!p.GetNumber("rate", 0, 1e6, &o.rate) ||
      !p.GetInt("window", 0, dds::kFrameHistoryDepth - 1, &window) ||
      !p.GetNumber("loop-minutes", 0, 1e6, &o.loop_minutes) ||
      !p.GetInt("detection-wait-ms", 0, 3600000, &wait_ms) || !p.GetInt("domain", -1, 232, &domain))
    return p.exit_code();
  o.window = static_cast<int>(window);
  o.detection_wait = std::chrono::milliseconds(wait_ms);
  o.domain_id = static_cast<int>(domain);
  o.run_detector = !p.Flag("no-detector");
  o.run_mapper = !p.Flag("no-mapper");
  o.partition = p.Get("partition");
  o.security_dir = p.Get("security");
  if (p.Has("dds-interface")) {
    std::stringstream list(p.Get("dds-interface"));
    for (std::string address; std::getline(list, address, ',');) {
      if (!address.empty()) o.network.interfaces.push_back(address);
    }
  }
  o.network.shared_memory = !p.Flag("no-shm");
  o.network.discovery_server = p.Get("discovery-server");
  try {
    o.network.Check();
  } catch (const InvalidOptions& e) {
    return p.UsageError("--dds-interface / --discovery-server: " + EchoValue(e.what(), 400));
  }
  o.progress = p.Flag("progress");
  o.wait_for_components = p.Flag("wait-for-components");

  o.processes = p.Flag("processes");
  return 0;
}

int RunComponentCommand(const std::vector<std::string>& args) {
  ArgParser p(
      "component",
      "NAME --dataset DIR --config FILE [--out DIR] [--filter MODE] [--frames FIRST:LAST] "
      "[--deterministic] [--domain N] ...",
      "Runs one pipeline component (player | detector | slam | mapper | recorder) as its own\n"
      "process over Fast DDS (the transport benchmark is its own tool: dygslam_bench_transport).");
  DefineComponentOptions(&p);
  p.AllowEmptyValues();
  if (!p.Parse(args)) return p.exit_code();
  if (!CheckFilterOption(&p)) return 2;
  // Everything the command line can get wrong is a usage error (exit 2) naming the option as the
  // user types it, found before any DDS participant exists.
  const std::string name = p.Positional("NAME");
  static const char* const kNames[] = {"player", "detector", "slam",
                                       "mapper", "recorder", "pipeline"};
  if (std::find(std::begin(kNames), std::end(kNames), name) == std::end(kNames))
    return p.UsageError("unknown component '" + EchoValue(name) +
                        "' (expected player | detector | slam | mapper | recorder | pipeline; "
                        "the transport benchmark is the tool dygslam_bench_transport)");

  PipelineOptions o;
  if (const int code = ReadComponentFiles(p, name, &o); code != 0) return code;
  if (const int code = ReadComponentMapsAndModel(p, name, &o); code != 0) return code;
  if (const int code = ReadComponentTransport(p, &o); code != 0) return code;
  if (name == "pipeline") return RunPipeline(o);  // the whole pipeline
  auto stop = std::make_shared<StopFlag>(StopFlag::Signals::kStop);
  return RunComponent(name, o, stop);
}

const CommandRegistrar kRegistrar({"component", "(internal) run one DDS pipeline component",
                                   RunComponentCommand});

}  // namespace
}  // namespace dygslam::cli
#endif  // DYGSLAM_HAVE_COMPONENTS
