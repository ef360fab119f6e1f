#include "components/pipeline.h"

#include <fcntl.h>
#include <malloc.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <thread>

#include "components/dds/participant.h"
#include "components/dds/pubsub.h"
#include "components/dds/qos.h"
#include "components/detector_component.h"
#include "components/mapper_component.h"
#include "components/player.h"
#include "components/recorder.h"
#include "components/slam_component.h"
#include "core/base/child_process.h"
#include "core/base/echo.h"
#include "core/base/error.h"
#include "core/base/log.h"
#include "core/base/stop_signal.h"
#include "core/base/thread_setup.h"
#include "core/dynamic/yolo_detector.h"
#include "core/io/file_util.h"
#include "dygslam_msg/StreamStatusPubSubTypes.h"
#include "run/realtime_report.h"

namespace dygslam {

namespace fs = std::filesystem;

// ---------------------------------------------------------------------------------------------
// Options.

void PipelineOptions::Check() const {
  DYGSLAM_CHECK_OPTION(!dataset_dir.empty(), "dataset_dir");
  DYGSLAM_CHECK_OPTION(!output_dir.empty(), "output_dir");
  system.Check();
  DYGSLAM_CHECK_OPTION(rate >= 0, "rate");
  DYGSLAM_CHECK_OPTION(window >= 0 && window < dds::kFrameHistoryDepth, "window");
  DYGSLAM_CHECK_OPTION(detection_wait.count() >= 0, "detection_wait_ms");
  DYGSLAM_CHECK_OPTION(domain_id >= -1 && domain_id <= 232, "domain_id");
  DYGSLAM_CHECK_OPTION(!processes || !settings_path.empty(),
                       "settings_path (required with --processes: the children re-read it)");
  DYGSLAM_CHECK_OPTION(last_entry == 0 || last_entry > first_entry, "frames (empty range)");
  DYGSLAM_CHECK_OPTION(flush_timeout_s >= 0, "flush_timeout_s");
  DYGSLAM_CHECK_OPTION(loop_minutes >= 0 && std::isfinite(loop_minutes), "loop_minutes");
  network.Check();
}

void CheckComponentRequest(const std::string& name, const PipelineOptions& o,
                           const std::string& settings_example) {
  if (!std::set<std::string>{"player", "detector", "slam", "mapper", "recorder", "pipeline"}.count(
          name))
    throw UsageError("unknown component '" + EchoValue(name) +
                     "' (expected player | detector | slam | mapper | recorder | pipeline; the "
                     "transport benchmark is the tool dygslam_bench_transport)");
  if (o.settings_path.empty())
    throw UsageError("--config FILE is required: the settings YAML of the run (" +
                     settings_example + ")");
  if ((o.dataset_dir.empty() || o.dataset_dir == "-") && (name == "player" || name == "pipeline"))
    throw UsageError("the " + name +
                     " needs --dataset DIR: the dataset folder that holds rgb.txt and depth.txt "
                     "(e.g. --dataset data/bonn_crowd_part)");
  if (o.output_dir.empty()) throw UsageError("--out: empty folder name");
}

void CheckDetectorModelOption(const std::string& model) {
  try {
    DetectorOptionsForModel(model);
  } catch (const InputError& e) {
    throw InputError(std::string("--detector-model: ") + e.what());
  }
}

bool PipelineOptions::NeedsDetectorComponent() const {
  return run_detector && system.NeedsDetections();
}

namespace {

// glibc gives each thread that allocates concurrently its own malloc arena (up to 8 per core) and
// an arena keeps freed memory for reuse by its own threads. The pipeline has dozens of threads
// (Fast DDS receive / event threads, one per component, local mapping, OpenCV) that allocate
// and free 0.3-2.5 MB image buffers: with the default, resident memory of `dygslam run` rose
// ~0.2 MB per frame even with bounded DDS histories (second half of 360 frames; 0.03 MB per
// frame with 2 arenas, measured, BENCHMARKS.md). Called before any component thread
// starts; applies to the arenas created after it.
void BoundMallocArenas() {
  static std::once_flag once;
  std::call_once(once, [] { mallopt(M_ARENA_MAX, 2); });
}

int DomainId(const PipelineOptions& options) {
  return options.domain_id >= 0 ? options.domain_id : dds::DomainIdFromEnvironment(0);
}

std::string Number(double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.17g", v);
  return buf;
}

DetectorOptions DetectorOptionsFor(const PipelineOptions& options) {
  DetectorOptions d;
  if (!options.system.detector.cfg_path.empty()) {
    d = options.system.detector;
  } else {
    d = DetectorOptionsForModel(options.detector_model);
    d.confidence_threshold = options.system.detector.confidence_threshold;
  }
  // One OpenCV thread: the detector shares the 2 cores with slam; same count in both modes so
  // single- and multi-process runs compute identical detections. (cv::setNumThreads is
  // process-wide; the settings' count instead was measured: no gain on the loaded
  // 2-core machine, 0.97x frames/s, see BENCHMARKS.md.)
  d.num_threads = 1;
  return d;
}

}  // namespace

std::vector<std::string> ComponentArgs(const PipelineOptions& o) {
  std::vector<std::string> a = {
      "--dataset",
      o.dataset_dir,
      "--out",
      o.output_dir,
      "--config",
      o.settings_path,
      "--filter",
      ToString(o.system.filter.mode),
      "--detector-model",
      o.detector_model,
      "--frames",
      std::to_string(o.first_entry) + ":" + (o.last_entry ? std::to_string(o.last_entry) : ""),
      "--rate",
      Number(o.rate),
      "--window",
      std::to_string(o.window),
      "--detection-wait-ms",
      std::to_string(o.detection_wait.count()),
      "--domain",
      std::to_string(DomainId(o))};
  if (!o.partition.empty()) a.insert(a.end(), {"--partition", o.partition});
  if (o.loop_minutes > 0) a.insert(a.end(), {"--loop-minutes", Number(o.loop_minutes)});
  if (!o.security_dir.empty()) a.insert(a.end(), {"--security", o.security_dir});
  if (!o.network.interfaces.empty()) {
    std::string list;
    for (const std::string& address : o.network.interfaces)
      list += (list.empty() ? "" : ",") + address;
    a.insert(a.end(), {"--dds-interface", list});
  }
  if (!o.network.shared_memory) a.push_back("--no-shm");
  if (!o.network.discovery_server.empty()) {
    a.insert(a.end(), {"--discovery-server", o.network.discovery_server});
  }
  if (o.system.deterministic) a.push_back("--deterministic");
  if (!o.system.load_map.empty()) a.insert(a.end(), {"--load-map", o.system.load_map});
  if (o.system.localization) a.push_back("--localization");
  if (!o.save_map.empty()) a.insert(a.end(), {"--save-map", o.save_map});
  if (!o.load_octomap.empty()) a.insert(a.end(), {"--load-octomap", o.load_octomap});
  if (o.progress) a.push_back("--progress");
  if (o.wait_for_components) a.push_back("--wait-for-components");
  if (!o.run_detector) a.push_back("--no-detector");
  if (!o.run_mapper) a.push_back("--no-mapper");
  if (!o.system.detector.cfg_path.empty()) {
    a.insert(a.end(),
             {"--detector-cfg", o.system.detector.cfg_path, "--detector-weights",
              o.system.detector.weights_path, "--detector-names", o.system.detector.names_path});
  }
  return a;
}

namespace {

std::vector<ComponentKind> PipelineComponents(const PipelineOptions& options) {
  // Consumers first, the player last.
  std::vector<ComponentKind> kinds = {ComponentKind::kRecorder};
  if (options.run_mapper) kinds.push_back(ComponentKind::kMapper);
  kinds.push_back(ComponentKind::kSlam);
  if (options.NeedsDetectorComponent()) kinds.push_back(ComponentKind::kDetector);
  kinds.push_back(ComponentKind::kPlayer);
  return kinds;
}

// A player whose frames the run's consumers refused (another frame source started first): it
// failed, but says so to no one on the partition (a FAILED would end the other source's run).
struct FrameSourceRefused : std::runtime_error {
  FrameSourceRefused() : std::runtime_error("the frames of this player were refused") {}
};

// What a component reports when it ends: the samples it ignored (writers outside this run), and
// why its part of the run is incomplete ("" when it is not): its input ended without the end of
// the run reaching it, or messages it published did not reach their reader.
struct ComponentOutcome {
  size_t ignored_samples = 0;
  std::string incomplete;
};
constexpr const char* kInputEndedEarly = "its input ended early";
std::string InputEndedEarly(bool cut_short) { return cut_short ? kInputEndedEarly : ""; }

// The player of the pipeline: the dataset's frames, paced or windowed; with --rate the real-time
// report into the run's output folder.
ComponentOutcome RunPipelinePlayer(const PipelineOptions& options,
                                   std::shared_ptr<dds::Participant> participant,
                                   const StopFlagPtr& stop) {
  PlayerOptions p;
  p.dataset_dir = options.dataset_dir;
  p.camera = options.system.camera;
  p.depth_scale = options.system.sensor.depth_map_factor;
  p.rate = options.rate;
  p.first_entry = options.first_entry;
  p.last_entry = options.last_entry;
  p.window = options.window;
  p.loop_minutes = options.loop_minutes;
  p.expected_readers = options.NeedsDetectorComponent() ? 2 : 1;
  p.watch_consumers = !options.judged_by_runner;
  if (options.wait_for_components) {
    for (const ComponentKind component : PipelineComponents(options)) {
      if (component != ComponentKind::kPlayer) p.wait_for_components.push_back(component);
    }
  }
  // The real-time report goes into the output folder this run started with, wherever it is
  // when the player ends (WriteFileAtomically follows a pinned folder; a component process
  // pins it here, a run in one process pinned it already).
  if (options.rate > 0) {
    std::error_code ec;
    fs::create_directories(options.output_dir, ec);
    PinOutputFolder(options.output_dir);
  }
  const PlayerStats stats = RunPlayer(participant, p, stop);
  if (options.rate > 0) {
    RealtimeReport report;
    report.rate = options.rate;
    report.frames = stats.frames_published;
    report.results = stats.poses_timed;
    report.late = stats.late;
    report.latency_median_ms = stats.latency_median_ms;
    report.latency_p99_ms = stats.latency_p99_ms;
    report.longest_gap_s = stats.longest_gap_s;
    report.latencies = stats.latencies;
    WriteRealtimeReport((fs::path(options.output_dir) / kRealtimeReportFile).string(), report);
  }
  if (stats.refused) throw FrameSourceRefused();
  return {0, InputEndedEarly(stats.slam_left_early || stats.recorder_left_early ||
                             stats.mapper_left_early)};
}

// slam of the pipeline, with the detector's settings for the keyframes the detector skips.
ComponentOutcome RunPipelineSlam(const PipelineOptions& options,
                                 std::shared_ptr<dds::Participant> participant,
                                 const StopFlagPtr& stop) {
  SlamComponentOptions s;
  s.system = options.system;
  s.external_detections = options.run_detector;
  if (s.external_detections) {
    // Keyframes made on frames the detector component skipped (Detector.every_n_frames > 1)
    // get their map mask from slam's own detector, the detector component's model and
    // thread count (created on first use; SystemOptions::detect_skipped_keyframes). Without
    // a mapper nobody uses the masks: no detection. A slam host without the models (the
    // detector on another host) keeps the carried boxes for those masks, with a warning.
    const bool detect = options.system.detect_skipped_keyframes && options.run_mapper &&
                        options.system.detection_every_n_frames > 1;
    s.system.detect_skipped_keyframes = false;
    if (detect) {
      try {
        s.system.detector = DetectorOptionsFor(options);
        s.system.detect_skipped_keyframes = true;
      } catch (const InputError& e) {
        LOG_WARNING << "slam: keyframes on frames the detector skips keep the carried boxes "
                       "for their map mask (no detector model here: "
                    << e.what() << ")";
      }
    }
  }
  s.detection_wait = options.detection_wait;
  s.save_map = options.save_map;
  const SlamStats stats = RunSlam(participant, s, stop);
  // The final trajectories are out (the recorder writes them): now the map file's failure.
  if (!stats.save_map_error.empty()) throw InputError(stats.save_map_error);
  const size_t foreign = stats.foreign_frames + stats.foreign_detections + stats.foreign_statuses;
  if (stats.keyframe_messages_undelivered > 0)
    return {foreign, std::to_string(stats.keyframe_messages_undelivered) +
                         " keyframe messages not delivered: the map lacks them"};
  // Frames due their own boxes that ran with none (the detector lost: paused, gone or more than
  // the detection wait behind, and no recent boxes to carry): filtered geometry-only, not as the
  // run asked. The poses are there; the run is not what was requested.
  const size_t without_boxes = stats.frames_without_boxes;
  if (without_boxes > 0 && !stats.input_cut_short)
    return {foreign, std::to_string(without_boxes) +
                         " frames ran without person boxes (geometry-only): the detector " +
                         (stats.detector_failed ? "failed"
                          : stats.detector_lost ? "was lost"
                                                : "was late")};
  return {foreign, InputEndedEarly(stats.input_cut_short)};
}

ComponentOutcome RunComponentKind(ComponentKind kind, const PipelineOptions& options,
                                  std::shared_ptr<dds::Participant> participant,
                                  const StopFlagPtr& stop) {
  switch (kind) {
    case ComponentKind::kPlayer:
      return RunPipelinePlayer(options, participant, stop);
    case ComponentKind::kDetector:
      RunDetector(participant, DetectorOptionsFor(options), stop,
                  options.system.detection_every_n_frames);
      return {};
    case ComponentKind::kSlam:
      return RunPipelineSlam(options, participant, stop);
    case ComponentKind::kMapper: {
      MapperOptions m;
      m.map_path = (fs::path(options.output_dir) / "map.bt").string();
      m.base_map_path = options.load_octomap;
      // With --save-map the OctoMap with probabilities too, what --load-octomap continues (as the
      // direct mode writes it).
      if (!options.save_map.empty())
        m.full_map_path = (fs::path(options.output_dir) / "map.ot").string();
      m.flush_timeout_s = options.flush_timeout_s;
      m.octomap = options.octomap;
      fs::create_directories(options.output_dir);
      const MapperStats stats = RunMapper(participant, m, stop);
      return {stats.foreign_samples, InputEndedEarly(stats.input_cut_short)};
    }
    case ComponentKind::kRecorder: {
      RecorderOptions r;
      r.output_dir = options.output_dir;
      r.flush_timeout_s = options.flush_timeout_s;
      r.progress = options.progress;
      const RecorderStats stats = RunRecorder(participant, r, stop);
      if (stats.poses_missed > 0 && !stats.input_cut_short)
        return {stats.foreign_samples, std::to_string(stats.poses_missed) +
                                           " per-frame poses never arrived: frames.csv lacks them"};
      return {stats.foreign_samples, InputEndedEarly(stats.input_cut_short)};
    }
    case ComponentKind::kRos2Bridge:
      break;
  }
  throw InvalidOptions(std::string("component '") + ToString(kind) +
                       "' is not run by the pipeline (" + PipelineComponentNames() + ")");
}

// Runs component `kind`; one that fails announces FAILED with the reason on the status topic
// (its peers react: slam finishes when the frame source failed, mapper and recorder write what
// they have when slam failed) and the error goes on to the caller.
// 0, or kExitComponentCutShort when the component's part of the run is incomplete (its outputs
// are written; *incomplete says why). Throws when the component failed.
int RunComponentOn(ComponentKind kind, const PipelineOptions& options,
                   std::shared_ptr<dds::Participant> participant, const StopFlagPtr& stop,
                   size_t* ignored_samples, std::string* incomplete) {
  try {
    const ComponentOutcome outcome = RunComponentKind(kind, options, participant, stop);
    *ignored_samples += outcome.ignored_samples;
    *incomplete = outcome.incomplete;
    if (!outcome.incomplete.empty()) return kExitComponentCutShort;
  } catch (const FrameSourceRefused&) {
    return 1;  // the player said why
  } catch (const std::exception& e) {
    try {
      dds::Writer<msg::StreamStatusPubSubType> status(participant, dds::topics::kStreamStatus,
                                                      dds::TopicKind::kStreamStatus);
      // A component that fails at start fails before discovery is done: give the peers' status
      // readers a moment to match (bounded), then wait until they have the announcement.
      status.WaitForReaders(1, std::chrono::seconds(3));
      std::this_thread::sleep_for(std::chrono::milliseconds(500));
      status.Write(ToMsg(ComponentStatus::Failed(kind, e.what())));
      status.WaitForAcknowledgments(std::chrono::milliseconds(2000));
    } catch (const std::exception&) {
      // The announcement is a courtesy; the error itself is what matters.
    }
    throw;
  }
  return 0;
}

ComponentKind ComponentKindOrThrow(const std::string& name) {
  const auto kind = ComponentKindFromName(name);
  if (!kind || *kind == ComponentKind::kRos2Bridge) {
    throw InvalidOptions("unknown component '" + name + "' (" + PipelineComponentNames() + ")");
  }
  return *kind;
}

// PipelineOptions::security_dir -> the credentials of component `name`.
dds::SecurityOptions ComponentSecurity(const std::string& dir, const std::string& name) {
  if (dir.empty()) return dds::SecurityOptions();
  const std::filesystem::path root(dir);
  std::error_code ec;
  if (std::filesystem::exists(root / "cert.pem", ec))
    return dds::SecurityOptions::FromDirectory(dir);
  return dds::SecurityOptions::FromDirectory(
      (root / (name == "pipeline" ? "slam" : name)).string());
}

std::shared_ptr<dds::Participant> MakeParticipant(const PipelineOptions& options,
                                                  const std::string& name) {
  dds::ParticipantOptions p;
  p.domain_id = DomainId(options);
  p.name = "dygslam_" + name;
  p.partition = options.partition;
  p.security = ComponentSecurity(options.security_dir, name);
  p.network = options.network;
  return dds::Participant::Create(p);
}

// A component whose part is incomplete for a reason of its own (messages that did not arrive) is
// listed in report->components_cut_short, as with --processes; a failed one makes the result 1.
int RunSingleProcess(const PipelineOptions& options, const StopFlagPtr& stop, StopReport* report) {
  auto participant = MakeParticipant(options, "pipeline");
  std::map<ComponentKind, int> codes;
  std::mutex mutex;
  std::vector<std::thread> threads;
  for (const ComponentKind kind : PipelineComponents(options)) {
    threads.emplace_back([&, kind] {
      SetCurrentThreadName(ToString(kind));
      int code = 1;
      size_t ignored = 0;
      std::string incomplete;
      try {
        code = RunComponentOn(kind, options, participant, stop, &ignored, &incomplete);
      } catch (const std::exception& e) {
        LOG_ERROR << ToString(kind) << ": " << e.what();
        stop->Request();  // one component failed: stop the others (they flush)
      }
      std::lock_guard<std::mutex> lock(mutex);
      codes[kind] = code;
      report->ignored_samples += ignored;
      // In one process no component ends alone: an input that ended early is the stream's cut
      // (the frame counts say it); other reasons (messages that did not arrive) are listed.
      if (code == kExitComponentCutShort && incomplete != kInputEndedEarly)
        report->components_cut_short.push_back(std::string(ToString(kind)) + " (" + incomplete +
                                               ")");
    });
  }
  for (std::thread& t : threads) t.join();
  int result = 0;
  for (const auto& [kind, code] : codes) {
    if (code != 0 && code != kExitComponentCutShort) result = 1;
  }
  return result;
}

// True when child PID runs the component (exec done: between fork and exec it still carries the
// runner's handlers, and a signal it takes there is lost) and /proc/PID/status lists `sig` among
// the signals it catches (SigCgt: its main() has installed the handler).
// CPU time (user + system) that process `pid` has used, in seconds; negative when unreadable.
double ProcessCpuSeconds(pid_t pid) {
  const std::string stat = ReadProcessFile(pid, "stat");
  const size_t paren = stat.rfind(')');
  if (paren == std::string::npos) return -1;
  std::istringstream fields(stat.substr(paren + 1));
  std::string field;
  // After the name: state (field 3) ... utime (14), stime (15).
  long long ticks = 0;
  for (int k = 3; k <= 15 && fields >> field; ++k) {
    if (k >= 14) ticks += std::atoll(field.c_str());
  }
  const long per_second = sysconf(_SC_CLK_TCK);
  return fields && per_second > 0 ? static_cast<double>(ticks) / per_second : -1;
}

bool ComponentCatchesSignal(pid_t pid, ComponentKind component, int sig) {
  const std::string cmdline = ReadProcessFile(pid, "cmdline");
  if (cmdline.find(std::string("component") + '\0' + ToString(component) + '\0') ==
      std::string::npos)
    return false;
  return ProcessCatchesSignal(pid, sig);
}

// --processes: each child tells the runner how many samples of foreign writers it ignored (for
// the run summary, as in the single-process mode) and the stop signal it received, if any,
// through a pipe whose write end it inherits; the descriptor's number is in this environment
// variable.
constexpr const char* kReportFdVariable = "DYGSLAM_COMPONENT_REPORT_FD";

void ReportToRunner(size_t ignored, int stop_signal, const std::string& incomplete) {
  const char* fd_text = std::getenv(kReportFdVariable);
  if (fd_text == nullptr) return;
  char* end = nullptr;
  const long fd = std::strtol(fd_text, &end, 10);
  if (end == fd_text || *end != '\0' || fd < 0) return;
  std::string line = std::to_string(ignored) + " " + std::to_string(stop_signal);
  if (!incomplete.empty()) line += " " + incomplete;
  line += "\n";
  if (write(static_cast<int>(fd), line.data(), line.size()) < 0) {
    LOG_WARNING << "could not report the ignored-sample count to the runner: "
                << std::strerror(errno);
  }
  close(static_cast<int>(fd));
}

// What a child reported (zeros when nothing: it died before reporting). Closes `fd`.
struct ChildReport {
  size_t ignored_samples = 0;
  int stop_signal = 0;     // the stop signal the child received (0: none)
  std::string incomplete;  // why its part is incomplete (ComponentOutcome), "" when it is not
};
ChildReport ReadChildReport(int fd) {
  std::string text;
  char buffer[64];
  ssize_t n = 0;
  while ((n = read(fd, buffer, sizeof(buffer))) > 0) text.append(buffer, n);
  close(fd);
  ChildReport report;
  char* end = nullptr;
  const unsigned long long value = std::strtoull(text.c_str(), &end, 10);
  if (end == text.c_str()) return report;
  report.ignored_samples = static_cast<size_t>(value);
  char* sig_end = nullptr;
  const long sig = std::strtol(end, &sig_end, 10);
  if (sig_end != end && sig > 0 && sig < 65) report.stop_signal = static_cast<int>(sig);
  if (sig_end != end && *sig_end == ' ') {
    report.incomplete = sig_end + 1;
    if (const size_t eol = report.incomplete.find('\n'); eol != std::string::npos)
      report.incomplete.resize(eol);
  }
  return report;
}

// How long the others may go on with the frames a frame source sent before it was stopped on its
// own (slam's final bundle adjustment included), at most...
constexpr std::chrono::seconds kSourceCutShortGrace(60);
// ... and once they do no work (together under 0.1 s of CPU in this time): nothing more comes.
constexpr std::chrono::seconds kSourceCutShortIdle(3);
// After slam's end, a mapper still running alone that does no work (under 0.1 s of CPU in
// kMapperAfterSlamGrace) is told to stop. A mapper working through its backlog is left to finish
// it; one that never matched slam (paused through slam's whole life) would wait for ever.
constexpr std::chrono::seconds kMapperAfterSlamGrace(10);

// Between the starts of two secured component processes (see ComponentProcesses).
constexpr std::chrono::milliseconds kSecureStartStagger(1500);

// Starts `exe component KIND ARGS` as a child of this run (it dies with the run) with the write
// end of a report pipe whose read end goes to *report_fd. Returns its pid.
pid_t StartComponentProcess(const std::string& exe, ComponentKind kind,
                            const std::vector<std::string>& args, int* report_fd) {
  ChildProcessOptions child;
  child.argv = {exe, "component", ToString(kind)};
  child.argv.insert(child.argv.end(), args.begin(), args.end());
  int report_pipe[2] = {-1, -1};
  if (pipe2(report_pipe, O_CLOEXEC) != 0) {
    throw std::runtime_error(std::string("pipe: ") + std::strerror(errno));
  }
  child.set_env = {{kReportFdVariable, std::to_string(report_pipe[1])}};
  child.keep_fds = {report_pipe[1]};  // the write end survives the exec
  // A run killed outright (SIGKILL) takes its components with it: left running, they would
  // finish later and write over the outputs of the next run into the same folder.
  child.dies_with_parent = true;
  pid_t pid = -1;
  try {
    pid = StartChildProcess(child);
  } catch (...) {
    close(report_pipe[0]);
    close(report_pipe[1]);
    throw;
  }
  close(report_pipe[1]);
  *report_fd = report_pipe[0];
  LOG_INFO << "started component " << ToString(kind) << " (pid " << pid << ")";
  return pid;
}

// The component processes of a `run --processes`: started, watched, stopped together.
class ComponentProcesses {
 public:
  ComponentProcesses(const PipelineOptions& options, StopFlagPtr stop, StopReport* report)
      : stop_(std::move(stop)), report_(report) {
    const std::string exe = options.executable.empty() ? fs::read_symlink("/proc/self/exe").string()
                                                       : options.executable;
    const std::vector<std::string> args = ComponentArgs(options);
    for (const ComponentKind kind : PipelineComponents(options)) {
      // Secured components join one at a time: Fast DDS 2.9 can lose the match between two
      // participants when a third one is discovered while their authentication is under way
      // (a data race in its participant discovery), and the pair then never talks.
      if (!options.security_dir.empty() && !children_.empty()) stop_->WaitFor(kSecureStartStagger);
      int report_fd = -1;
      const pid_t pid = StartComponentProcess(exe, kind, args, &report_fd);
      reports_[pid] = report_fd;
      children_[pid] = kind;
    }
  }

  // Until every component ended: 0, or 1 when one whose failure fails the run failed.
  int Supervise() {
    while (!children_.empty()) {
      StopAfterSourceCutShort();
      StopMapperLeftAlone();
      int status = 0;
      const pid_t pid = waitpid(-1, &status, WNOHANG);
      if (pid > 0) {
        if (children_.count(pid) > 0) Reap(pid, status);  // else not one of ours
        continue;
      }
      if (stop_->requested()) ForwardStop();
      if (forwarded_ && Clock::now() - stop_time_ > std::chrono::seconds(30)) KillStragglers();
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return run_failed_ ? 1 : 0;
  }

 private:
  using Clock = std::chrono::steady_clock;

  // A frame source stopped on its own before its peers had matched it: they never see its end of
  // stream and would wait for ever. The run is incomplete anyway; once the others have done no
  // work for kSourceCutShortIdle (the frames it sent are processed), or after
  // kSourceCutShortGrace at most, they are stopped (they write what they have).
  void StopAfterSourceCutShort() {
    if (!source_cut_short_at_ || forwarded_) return;
    const auto now = Clock::now();
    double cpu = 0;
    for (const auto& [p, k] : children_) cpu += std::max(0.0, ProcessCpuSeconds(p));
    const bool idle = source_idle_check_ && cpu - source_idle_check_->second <= 0.1 &&
                      now - source_idle_check_->first > kSourceCutShortIdle;
    const bool over = now - *source_cut_short_at_ > kSourceCutShortGrace;
    if (!idle && !over) {
      if (!source_idle_check_ || cpu - source_idle_check_->second > 0.1)
        source_idle_check_ = std::make_pair(now, cpu);  // working: checked again later
      return;
    }
    if (idle) {
      LOG_WARNING << "the frame source was stopped on its own and the other components have done "
                  << "no work for " << kSourceCutShortIdle.count() << " s: stopping them";
    } else {
      LOG_WARNING << "the frame source was stopped on its own " << kSourceCutShortGrace.count()
                  << " s ago and the run has not ended: stopping the other components";
    }
    stop_->Request();
    source_cut_short_at_.reset();
  }

  // slam has ended and only map stages remain: one that did no work in the last
  // kMapperAfterSlamGrace is stopped (it writes the map it has and judges its own part; a mapper
  // that missed slam's keyframes says so and makes the run incomplete).
  void StopMapperLeftAlone() {
    if (!slam_ended_at_ || forwarded_) return;
    for (const auto& [p, k] : children_) {
      if (k != ComponentKind::kMapper) return;
    }
    const auto now = Clock::now();
    if (now - *slam_ended_at_ <= kMapperAfterSlamGrace) return;
    double cpu = 0;
    for (const auto& [p, k] : children_) cpu += std::max(0.0, ProcessCpuSeconds(p));
    if (!idle_check_ || cpu - idle_check_->second > 0.1) {
      idle_check_ = std::make_pair(now, cpu);  // working: checked again a grace later
      return;
    }
    if (now - idle_check_->first <= kMapperAfterSlamGrace) return;
    LOG_WARNING << "slam ended and the mapper has done no work for "
                << kMapperAfterSlamGrace.count() << " s: stopping it (it writes the map it has)";
    stop_->Request();
    slam_ended_at_.reset();
  }

  // A child ended: what it reported, why it ended, whether the others go on.
  void Reap(pid_t pid, int status) {
    const ComponentKind kind = children_[pid];
    const char* name = ToString(kind);
    children_.erase(pid);
    if (kind == ComponentKind::kSlam) slam_ended_at_ = Clock::now();
    const ChildReport child = ReadChildReport(reports_[pid]);
    reports_.erase(pid);
    report_->ignored_samples += child.ignored_samples;
    // A stop signal sent to this component alone (not the run's: the runner had not forwarded
    // one and received none itself) ended it before the stream did: its part of the run (the
    // map, the detections) covers the frames until then.
    if (child.stop_signal != 0 && !forwarded_ && !stop_->requested()) {
      LOG_WARNING << "component " << name << " (pid " << pid << ") was stopped by signal "
                  << child.stop_signal << " sent to it alone, before the end of the run";
      report_->components_cut_short.push_back(std::string(name) + " (signal " +
                                              std::to_string(child.stop_signal) + ")");
      if (IsFrameSource(kind)) source_cut_short_at_ = Clock::now();
    }
    // A component that did not stop when the run ended (paused, or hung) had stopped doing its
    // part before: what it gave (the detector's boxes, the map) may end early.
    if (killed_by_runner_.count(pid) > 0) {
      report_->components_cut_short.push_back(std::string(name) +
                                              " (did not stop at the end of the run: killed)");
    }
    JudgeExit(pid, kind, status, child.incomplete);
    // The run is over when the recorder (and mapper) have written their outputs.
    bool outputs_done = true;
    for (const auto& [p, k] : children_) {
      if (WritesOutputs(k)) outputs_done = false;
    }
    if (outputs_done && !forwarded_) stop_->Request();
  }

  void JudgeExit(pid_t pid, ComponentKind kind, int status, const std::string& incomplete) {
    const char* name = ToString(kind);
    const bool ok = WIFEXITED(status) && WEXITSTATUS(status) == 0;
    // After the outputs are written the runner stops the others with SIGTERM; a component that
    // was already tearing down (its handler restored) then dies of that signal: not a failure.
    const bool stopped_by_runner = forwarded_ && WIFSIGNALED(status) && WTERMSIG(status) == SIGTERM;
    // Its outputs are written, but its input ended without the end of the run.
    const bool cut_short = WIFEXITED(status) && WEXITSTATUS(status) == kExitComponentCutShort;
    if (cut_short) {
      const std::string why = incomplete.empty() ? kInputEndedEarly : incomplete;
      LOG_WARNING << "component " << name << " (pid " << pid << ") wrote its outputs, but its "
                  << "part of the run is incomplete: " << why << " (see its warning above)";
      report_->components_cut_short.push_back(std::string(name) + " (" + why + ")");
    } else if (stopped_by_runner) {
      LOG_INFO << "component " << name << " (pid " << pid << ") stopped at the end of the run";
    } else if (!ok) {
      LOG_WARNING << "component " << name << " (pid " << pid << ") "
                  << (WIFSIGNALED(status) ? "killed by signal " + std::to_string(WTERMSIG(status))
                                          : "exited with " + std::to_string(WEXITSTATUS(status)));
      if (FailureFailsRun(kind)) run_failed_ = true;
      // Without the frame source or slam nothing can go on: stop the others now (they flush
      // what they have) instead of waiting for an end of stream that never comes. A failed
      // detector is not a reason to stop: slam carries boxes forward / goes geometry-only.
      if (FailureStopsPipeline(kind) && !forwarded_) {
        LOG_ERROR << "a pipeline component failed (" << name << "); stopping the others";
        stop_->Request();
      }
    }
  }

  void ForwardStop() {
    if (!forwarded_) stop_time_ = Clock::now();
    forwarded_ = true;
    // A child signalled before its main() has installed the handler would die without writing
    // its outputs (or, between fork and exec, lose the signal): wait until it catches SIGTERM.
    const bool late = Clock::now() - stop_time_ > std::chrono::seconds(10);
    for (const auto& [p, n] : children_) {
      if (signalled_.count(p) == 0 && (late || ComponentCatchesSignal(p, n, SIGTERM))) {
        kill(p, SIGTERM);
        signalled_.insert(p);
      }
    }
  }

  void KillStragglers() {
    for (const auto& [p, n] : children_) {
      LOG_WARNING << "component " << ToString(n) << " did not stop; killing it";
      kill(p, SIGKILL);
      killed_by_runner_.insert(p);
    }
    stop_time_ = Clock::time_point::max();
  }

  StopFlagPtr stop_;
  StopReport* report_;
  std::map<pid_t, ComponentKind> children_;
  std::map<pid_t, int> reports_;  // read end of each child's report pipe
  bool forwarded_ = false;
  std::set<pid_t> signalled_;
  Clock::time_point stop_time_ = Clock::time_point::max();
  bool run_failed_ = false;
  std::optional<Clock::time_point> source_cut_short_at_;
  std::optional<Clock::time_point> slam_ended_at_;
  std::optional<std::pair<Clock::time_point, double>> idle_check_;  // when, mappers' CPU seconds
  // when, the other components' CPU seconds (after a frame source was stopped on its own)
  std::optional<std::pair<Clock::time_point, double>> source_idle_check_;
  std::set<pid_t> killed_by_runner_;  // did not stop within 30 s of the run's end
};

int RunProcesses(const PipelineOptions& options, const StopFlagPtr& stop, StopReport* report) {
  ComponentProcesses processes(options, stop, report);
  return processes.Supervise();
}

}  // namespace

int RunComponent(const std::string& name, const PipelineOptions& options, const StopFlagPtr& stop) {
  options.Check();
  BoundMallocArenas();
  const ComponentKind kind = ComponentKindOrThrow(name);
  PipelineOptions own = options;
  own.judged_by_runner = std::getenv(kReportFdVariable) != nullptr;  // a child of a run
  size_t ignored = 0;
  std::string incomplete;
  const int code =
      RunComponentOn(kind, own, MakeParticipant(own, name), stop, &ignored, &incomplete);
  ReportToRunner(ignored, stop->signal(), incomplete);
  // Started by hand (not a child of `run --processes`, whose summary names it): the exit code 3
  // says why here.
  if (!incomplete.empty() && !own.judged_by_runner)
    LOG_WARNING << name << ": its part of the run is incomplete: " << incomplete;
  return code;
}

int RunPipeline(const PipelineOptions& pipeline_options, StopReport* report) {
  pipeline_options.Check();
  BoundMallocArenas();
  PipelineOptions options = pipeline_options;
  options.wait_for_components = true;
  options.judged_by_runner = true;
  if (options.processes && !options.security_dir.empty()) {
    // Before any process starts: every component's credentials readable, its certificate issued
    // by its CA, and all of them trusting one CA (else they could not authenticate each other
    // and the run would stall in discovery).
    std::vector<std::pair<std::string, dds::SecurityOptions>> credentials;
    for (const ComponentKind kind : PipelineComponents(options))
      credentials.emplace_back(ToString(kind),
                               ComponentSecurity(options.security_dir, ToString(kind)));
    dds::CheckSameIdentityCa(credentials);
  }
  fs::create_directories(options.output_dir);
  auto stop = std::make_shared<StopFlag>(StopFlag::Signals::kStop);
  StopReport local;
  StopReport* out = report != nullptr ? report : &local;
  *out = StopReport{};
  const int code =
      options.processes ? RunProcesses(options, stop, out) : RunSingleProcess(options, stop, out);
  if (const int sig = stop->signal(); sig != 0) {
    LOG_INFO << "stopped by signal " << sig << "; outputs flushed";
  }
  if (report != nullptr) {
    report->signaled = stop->signal() != 0;
    return code;
  }
  // Without a caller to judge the run (`component pipeline`): a component cut short makes it
  // incomplete, like `run --processes`.
  if (code == 0 && !out->components_cut_short.empty()) {
    std::string names;
    for (const std::string& c : out->components_cut_short) names += (names.empty() ? "" : ", ") + c;
    LOG_ERROR << "the run is incomplete: " << names;
    return kExitComponentCutShort;
  }
  return code;
}

}  // namespace dygslam
