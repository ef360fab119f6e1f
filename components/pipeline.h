// The whole pipeline over DDS: player -> detector -> slam -> mapper + recorder.
//
//   PipelineOptions options;  options.dataset_dir = ...; options.system =
//   SystemOptionsFromSettings(..); options.settings_path = ...;   // re-read by the child processes
//   in --processes mode int code = RunPipeline(options);
//
// Single-process mode (default): every component runs on its own thread in this process, all on
// one DomainParticipant (Fast DDS intra-process delivery; no serialisation between components).
// Multi-process mode (processes = true): each component is a child process
// `<executable> component <name> <args>` (fork + exec of the same dygslam binary; the arguments
// are ComponentArgs()), all on the same domain; the runner waits for them and stops them at the
// end of data.
// End of data: the player announces END_OF_STREAM; slam finishes, publishes the final
// trajectories and COMPONENT_DONE; mapper and recorder write map.bt / trajectory.txt /
// keyframes.txt atomically and exit.
// SIGINT / SIGTERM: every component stops, flushes what it has (the recorder writes the final
// trajectory if slam managed to send it, else the online poses; the mapper writes the map) and
// RunPipeline returns 0. In multi-process mode the signal is forwarded (SIGTERM) to the children.
// Outputs in output_dir: trajectory.txt, keyframes.txt, frames.csv, trajectory_online.txt,
// groundtruth.txt, map.bt (if run_mapper).
#pragma once

#include <chrono>
#include <string>
#include <vector>

#include "components/component_common.h"
#include "components/dds/network_options.h"
#include "core/system/system.h"
#include "mapping/octomap_builder.h"

namespace dygslam {

struct PipelineOptions {
  std::string dataset_dir;
  std::string output_dir = "out/run";
  // Settings file of `system` (children of --processes re-read it with the same flags).
  std::string settings_path;
  SystemOptions system;    // camera, sensor, filter mode, deterministic, ...
  OctoMapOptions octomap;  // mapper (settings section OctoMap:)
  // Detector component model (DetectorOptionsForModel) unless system.detector.cfg_path is set.
  std::string detector_model = "yolo-fastest-1.1";
  size_t first_entry = 0, last_entry = 0;  // rgb.txt entries [first, last), last 0 = all
  double rate = 0;                         // player: 0 = as fast as consumed, 1 = real time
  // Player back-pressure window: 3 frames keep the player, the detector and tracking busy at once
  // (with 2, tracking waited for the next frame: 37 against 42 frames/s on bonn_crowd_part).
  int window = 3;
  double loop_minutes = 0;                 // player: replay the range for this long (soak)
  std::string save_map;                    // slam: SLAM map file written at the end
  std::string load_octomap;                // mapper: OctoMap (.ot) to continue
  std::chrono::milliseconds detection_wait{1000};
  bool processes = false;
  bool run_detector = true;  // detector component (filter modes boxes/full); false: System's own
  bool run_mapper = true;
  int domain_id = -1;  // -1: DYGSLAM_DOMAIN_ID or 0
  // DDS partition of every component ("" = default partition). `dygslam run` sets a name unique
  // to the run, so concurrent runs on one domain stay apart.
  std::string partition;
  // DDS Security credentials ("" = security off): either one identity folder (holding cert.pem;
  // every component uses it) or the OUT_DIR of scripts/make_dds_certs.sh with one identity
  // folder per component (OUT_DIR/player, .../slam, ...; the single-process pipeline uses slam's).
  std::string security_dir;
  // DDS interfaces / shared memory / discovery server (default: this machine only).
  dds::NetworkOptions network;
  bool progress = false;  // recorder prints a progress line on stderr
  // The player waits for the READY announcement of every other component of this pipeline
  // (set by RunPipeline; `dygslam component player --wait-for-components` by hand).
  bool wait_for_components = false;
  // A component of `dygslam run` (one process, or a child of --processes that reports to the
  // runner): the runner judges each component's end itself, so the player does not watch the
  // recorder and the mapper (by hand, with --wait-for-components, it does). Not an option.
  bool judged_by_runner = false;
  // On stop: how long mapper and recorder wait for slam's last outputs (seconds).
  double flush_timeout_s = 5.0;
  std::string executable;  // --processes: the dygslam binary (default /proc/self/exe)
  void Check() const;
  bool NeedsDetectorComponent() const;
};

// What `dygslam component NAME` needs before any DDS work, named as its command line names it: a
// known NAME, the settings file (`settings_example`: "e.g. PATH" of a preset), the dataset
// (player, pipeline), an output folder. Throws UsageError.
void CheckComponentRequest(const std::string& name, const PipelineOptions& options,
                           const std::string& settings_example);

// `dygslam component detector --detector-model NAME` (without --detector-cfg): NAME is a known
// model. Throws InputError naming the option.
void CheckDetectorModelOption(const std::string& model);

// Arguments after "dygslam component <name>" that reproduce `options` in a child process.
std::vector<std::string> ComponentArgs(const PipelineOptions& options);

// Runs one component in this process until it finishes or `stop` (used by
// `dygslam component <name>` and by the single-process mode). name: player | detector | slam |
// mapper | recorder. Returns 0 on success.
int RunComponent(const std::string& name, const PipelineOptions& options, const StopFlagPtr& stop);

struct StopReport {
  bool signaled = false;  // stopped by SIGINT / SIGTERM (outputs flushed)
  // Samples of writers no component of this run announced, ignored by slam, recorder and mapper
  // (components/protocol.h). With --processes each child reports its count to the runner when it
  // ends (a pipe); a child that died before reporting counts 0.
  size_t ignored_samples = 0;
  // Components whose part of the run is incomplete, with why: (--processes) a stop signal sent
  // to them alone ("mapper (signal 15)"); an input that ended without the end of the run ("mapper
  // (its input ended early)": the process was paused while slam finished); messages that did not
  // all arrive ("slam (12 keyframe messages not delivered: ...)"). Their part of the outputs
  // covers the frames until then, or lacks those messages.
  std::vector<std::string> components_cut_short;
};
// The exit code of a component whose outputs are written but whose input ended without the end
// of the run (the mapper or recorder missed slam's last samples): the run is incomplete.
inline constexpr int kExitComponentCutShort = 3;
// Runs the whole pipeline until the end of the data or a signal. Returns 0 on success (also when
// stopped by a signal), 1 if a component failed; without `report`, kExitComponentCutShort when a
// component ended before the run did (with a report, the caller judges the run).
int RunPipeline(const PipelineOptions& options, StopReport* report = nullptr);

}  // namespace dygslam
