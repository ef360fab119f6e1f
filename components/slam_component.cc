#include "components/slam_component.h"

#include <chrono>
#include <condition_variable>
#include <limits>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "components/dds/participant.h"
#include "components/dds/pubsub.h"
#include "components/sample_order.h"
#include "components/status_reader.h"
#include "core/base/error.h"
#include "core/base/log.h"
#include "dygslam_msg/CameraPosePubSubTypes.h"
#include "dygslam_msg/DetectionsPubSubTypes.h"
#include "dygslam_msg/KeyframePubSubTypes.h"
#include "dygslam_msg/RgbdFramePubSubTypes.h"
#include "dygslam_msg/StreamStatusPubSubTypes.h"
#include "dygslam_msg/TrajectoryPubSubTypes.h"

namespace dygslam {

namespace {
// Samples whose writer has not been announced (yet) wait at most this long / this many.
constexpr std::chrono::milliseconds kMaxHold{5000};
constexpr size_t kMaxHeldFrames = 32;
constexpr size_t kMaxHeldDetections = 256;
// A frame source whose writer is gone, with nothing new for this long, has ended (killed: its
// writer leaves with the participant's lease, 20 s by default).
constexpr std::chrono::seconds kSourceGone{5};
// Keyframe messages the writer refused wait for a reader that does not acknowledge (a paused
// mapper keeps the bounded history full) until it does or its lease (20 s) runs out; at most
// this many wait (memory stays bounded: most are small pose updates, new keyframes ~2.5 MB).
constexpr size_t kMaxPendingKeyframeMessages = 1024;
// At the end, the time the last keyframe messages get to be accepted: a lease and a margin.
constexpr std::chrono::milliseconds kKeyframeDeliveryTimeout{25000};

using Clock = FramePairer::Clock;

PairingOptions PairingOptionsFor(const SlamComponentOptions& options) {
  PairingOptions p;
  p.needs_detections = options.NeedsDetections();
  p.deterministic = options.system.deterministic;
  p.max_wait = options.detection_wait;
  p.lost_after_misses = options.detector_lost_after_misses;
  p.carry_forward_max_frames = options.carry_forward_max_frames;
  p.detection_every_n_frames = options.system.detection_every_n_frames;
  // slam holds no more frames than the frame topic's history: a windowed player (window <
  // kFrameHistoryDepth) is never cut; a camera's frames that slam cannot take in time are dropped.
  p.max_pending_frames = static_cast<size_t>(dds::kFrameHistoryDepth);
  return p;
}

// slam's shell: frames and detections pass the writer gates (only the writers this run's
// components announced) into the pairer; each paired frame goes through SlamCore, its pose and
// keyframes out; at the end the final trajectories, then DONE.
class SlamShell {
 public:
  SlamShell(std::shared_ptr<dds::Participant> participant, const SlamComponentOptions& options)
      : options_(options),
        core_(options),
        pairing_options_(PairingOptionsFor(options)),
        pairer_(pairing_options_),
        pose_writer_(participant, dds::topics::kCameraPose, dds::TopicKind::kCameraPose),
        keyframe_writer_(participant, dds::topics::kKeyframe, dds::TopicKind::kKeyframe),
        keyframe_sender_([this](const msg::Keyframe& m) { return keyframe_writer_.Write(m); },
                         kMaxPendingKeyframeMessages, std::chrono::milliseconds(100),
                         [](size_t pending) {
                           LOG_WARNING << "slam: a reader of the keyframe topic has not "
                                       << "acknowledged its history (a paused or stalled "
                                       << "mapper): holding " << pending << " keyframe "
                                       << "messages until it does or its lease runs out";
                         },
                         "keyframe sender"),
        trajectory_writer_(participant, dds::topics::kTrajectory, dds::TopicKind::kTrajectory),
        status_(participant, dds::topics::kStreamStatus, dds::TopicKind::kStreamStatus),
        frames_(participant, dds::topics::kRgbdFrame, dds::TopicKind::kRgbdFrame,
                [this](msg::RgbdFrame&& sample, const WriterGuid& writer) {
                  {
                    std::lock_guard<std::mutex> lock(mutex_);
                    std::vector<msg::RgbdFrame> ready;
                    frame_gate_.Offer(std::move(sample), writer, Clock::now(), &ready);
                    UseFrames(&ready);
                  }
                  cv_.notify_all();
                }),
        detections_(participant, dds::topics::kDetections, dds::TopicKind::kDetections,
                    [this](msg::Detections&& sample, const WriterGuid& writer) {
                      {
                        std::lock_guard<std::mutex> lock(mutex_);
                        WarnAboutSecondDetector(sample, writer);
                        std::vector<msg::Detections> ready;
                        detection_gate_.Offer(std::move(sample), writer, Clock::now(), &ready);
                        UseDetections(&ready);
                      }
                      cv_.notify_all();
                    }),
        status_reader_(participant, ComponentKind::kSlam,
                       [this](const ComponentStatus& s, const msg::StreamStatus& m,
                              const WriterGuid& from) { OnStatus(s, m, from); }),
        started_(status_,
                 ComponentStatus::Started(ComponentKind::kSlam,
                                          {{DataTopic::kCameraPose, pose_writer_.guid()},
                                           {DataTopic::kKeyframe, keyframe_writer_.guid()},
                                           {DataTopic::kTrajectory, trajectory_writer_.guid()}})) {}

  SlamStats Run(const StopFlagPtr& stop);

 private:
  // Admitted samples -> the pairer, in the order the gates admit them (under mutex_).
  void UseFrames(std::vector<msg::RgbdFrame>* ready);
  void UseDetections(std::vector<msg::Detections>* ready);
  // Held samples whose writer was announced meanwhile are used; expired ones counted (under
  // mutex_).
  void ReleaseHeld();
  // Boxes for one frame from two announced detector writers: a second detector on the run's
  // partition (it may run another model), or a restarted one catching up. The first that comes
  // is used; said once (under mutex_).
  void WarnAboutSecondDetector(const msg::Detections& sample, const WriterGuid& writer);
  void OnStatus(const ComponentStatus& s, const msg::StreamStatus& m, const WriterGuid& from);
  void PublishKeyframes(const std::vector<KeyframeData>& keyframes);
  // The map this slam starts from, announced once after READY (the readers are matched).
  void AnnounceLoadedMap();
  // The next paired frame; none when there is none yet (after a bounded wait) or, with *end,
  // when the stream is over.
  std::optional<PairedFrame> NextPaired(bool* end);
  // No frame ready (under `lock`): true when the stream is over.
  bool StreamOver();
  void Process(const PairedFrame& paired);
  void LogBoxes(const PairedFrame& paired);
  // `cut_short`: why the loop ended before the end of the stream ("" when it did not).
  void Finish(const std::string& cut_short);

  const SlamComponentOptions options_;
  SlamCore core_;
  SlamStats stats_;
  const PairingOptions pairing_options_;
  std::mutex mutex_;
  std::condition_variable cv_;
  FramePairer pairer_;  // guarded by mutex_
  int64_t end_frames_ = -1;
  size_t frames_received_ = 0;
  Clock::time_point last_frame_time_ = Clock::now();
  WriterGoneWatch source_watch_{kSourceGone};  // the frame source's writer, matched then gone
  int detector_writers_seen_ = 0;
  std::map<int64_t, double> inference_ms_;  // detector component's time per frame stamp (ns)
  bool detector_done_ = false;    // the detector announced COMPONENT_DONE (finished, not lost)
  bool detector_failed_ = false;  // the detector announced FAILED: no detections will come
  bool carrying_ = false;         // the previous frame ran with boxes carried forward (log once)
  BoxCoverage box_coverage_;
  bool geometry_only_ = false;  // the previous frame ran without any boxes (log once)
  bool waiting_ = false;        // after the first frame: no frame ready since wait_since_
  Clock::time_point wait_since_ = Clock::now();
  bool waited_with_frames_ = false;  // a frame was pending during that wait
  bool map_announced_ = false;
  // Frames and detections only from writers announced by this run's components (STARTED, see
  // components/protocol.h); early ones wait briefly for their writer's announcement.
  RunWriters run_writers_;  // guarded by mutex_
  WriterGate<msg::RgbdFrame> frame_gate_{&run_writers_, DataTopic::kFrames, kMaxHeldFrames,
                                         kMaxHold};
  WriterGate<msg::Detections> detection_gate_{&run_writers_, DataTopic::kDetections,
                                              kMaxHeldDetections, kMaxHold};
  std::map<int64_t, WriterGuid> detection_writers_;  // by frame stamp, the newest 512
  RepeatedWarning second_detector_warning_{1};
  RepeatedWarning rival_warning_;  // a rival announces itself again as peers join
  // The endpoints last: their listeners use the state above.
  dds::Writer<msg::CameraPosePubSubType> pose_writer_;
  dds::Writer<msg::KeyframePubSubType> keyframe_writer_;
  // Keyframe messages go out in order on their own thread: tracking never waits for a reader.
  OrderedSender<msg::Keyframe> keyframe_sender_;
  dds::Writer<msg::TrajectoryPubSubType> trajectory_writer_;
  dds::Writer<msg::StreamStatusPubSubType> status_;
  dds::Reader<msg::RgbdFramePubSubType> frames_;
  dds::Reader<msg::DetectionsPubSubType> detections_;
  StatusReader status_reader_;
  StartedAnnouncer started_;
};

void SlamShell::UseFrames(std::vector<msg::RgbdFrame>* ready) {
  for (msg::RgbdFrame& sample : *ready) {
    try {
      pairer_.AddFrame(RgbdFrameFromMsg(sample), Clock::now());
      ++frames_received_;
      last_frame_time_ = Clock::now();
    } catch (const InputError& e) {
      ++stats_.bad_samples;
      LOG_WARNING << "slam: dropped frame seq " << sample.header().seq() << ": " << e.what();
    }
  }
  ready->clear();
}

void SlamShell::UseDetections(std::vector<msg::Detections>* ready) {
  for (msg::Detections& sample : *ready) {
    try {
      std::vector<Detection> dets = DetectionsFromMsg(sample);
      const Timestamp stamp = TimeFromMsg(sample.header().stamp(), "Detections.header.stamp");
      inference_ms_[stamp.nanoseconds()] = sample.inference_ms();
      pairer_.AddDetections(stamp, std::move(dets));
    } catch (const InputError& e) {
      LOG_WARNING << "slam: dropped detections seq " << sample.header().seq() << ": " << e.what();
    }
  }
  ready->clear();
}

void SlamShell::ReleaseHeld() {
  std::vector<msg::RgbdFrame> ready_frames;
  std::vector<msg::Detections> ready_detections;
  frame_gate_.Release(Clock::now(), &ready_frames);
  detection_gate_.Release(Clock::now(), &ready_detections);
  UseFrames(&ready_frames);
  UseDetections(&ready_detections);
}

void SlamShell::WarnAboutSecondDetector(const msg::Detections& sample, const WriterGuid& writer) {
  if (!run_writers_.Owns(DataTopic::kDetections, writer)) return;
  const int64_t stamp = static_cast<int64_t>(sample.header().stamp().sec()) * 1000000000LL +
                        sample.header().stamp().nanosec();
  const auto [it, inserted] = detection_writers_.emplace(stamp, writer);
  if (!inserted && it->second != writer && second_detector_warning_.Say()) {
    LOG_WARNING << "slam: boxes for one frame came from two detectors (a second detector on "
                   "this run's partition, or a restarted one catching up): the first that "
                   "comes is used (give each run its own --partition)";
  }
  while (detection_writers_.size() > 512) detection_writers_.erase(detection_writers_.begin());
}

void SlamShell::OnStatus(const ComponentStatus& s, const msg::StreamStatus& m,
                         const WriterGuid& from) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!run_writers_.Announce(s, from)) {
      // A second frame source on the run's partition: its frames and its end of stream are not
      // this run's (its frames count as ignored in the summary).
      if (s.event == StreamEvent::kStarted && rival_warning_.Say()) {
        LOG_WARNING << "slam: rejected a second frame source on this run's partition: "
                    << run_writers_.LastRival() << " announced itself while the run's "
                    << "frame source plays; its frames are ignored (give each run its own "
                    << "--partition)";
      }
      return;
    }
    if (s.event == StreamEvent::kEndOfStream && IsFrameSource(s.source)) {
      end_frames_ = StreamFrameCountFromMsg(m);
      if (end_frames_ == std::numeric_limits<int64_t>::max()) {
        LOG_WARNING << "slam: END_OF_STREAM announces " << m.num_frames()
                    << " frames; finishing when the stream goes idle";
      }
    }
    if (s.event == StreamEvent::kFailed && IsFrameSource(s.source)) {
      // No more frames will come: finish with the ones that arrived.
      LOG_WARNING << "slam: the frame source (" << ToString(s.source) << ") failed: " << s.reason;
      end_frames_ = static_cast<int64_t>(frames_received_ + stats_.bad_samples);
    }
    if (s.event == StreamEvent::kComponentDone && s.source == ComponentKind::kDetector) {
      detector_done_ = true;
    }
    if (s.event == StreamEvent::kFailed && s.source == ComponentKind::kDetector) {
      LOG_WARNING << "slam: the detector failed: " << s.reason;
      detector_failed_ = true;
    }
    if (s.event == StreamEvent::kStarted) ReleaseHeld();
  }
  cv_.notify_all();
}

void SlamShell::PublishKeyframes(const std::vector<KeyframeData>& keyframes) {
  for (const KeyframeData& k : keyframes) {
    keyframe_sender_.Send(KeyframeToMsg(k, core_.camera()));
    ++stats_.keyframes_published;
    if (k.removed) {
      ++stats_.keyframes_removed;
    } else if (k.pose_update_only) {
      ++stats_.keyframe_pose_updates;
    }
  }
}

void SlamShell::AnnounceLoadedMap() {
  const MapFileInfo info = *core_.LoadedMapInfo();
  status_.Write(ToMsg(ComponentStatus::MapLoaded(ComponentKind::kSlam, info.keyframes,
                                                 info.checksum, options_.system.load_map)));
  LOG_INFO << "slam: started from map file " << options_.system.load_map << " ("
           << DescribeMapFile(info) << ")"
           << (options_.system.localization ? ", localization" : "");
  map_announced_ = true;
}

bool SlamShell::StreamOver() {
  const bool all_in = end_frames_ >= 0 &&
                      static_cast<int64_t>(frames_received_ + stats_.bad_samples) >= end_frames_;
  const bool stale_end = end_frames_ >= 0 && pairer_.pending_frames() == 0 &&
                         Clock::now() - last_frame_time_ > std::chrono::seconds(3);
  if ((all_in && pairer_.pending_frames() == 0) || stale_end) return true;
  // A frame source that left without its END_OF_STREAM (killed, or the announcement lost) would
  // leave slam waiting for ever: once its writer is gone and nothing arrived for kSourceGone,
  // finish with the frames that came.
  // (A peer unmatched after this process was suspended gets time to be discovered again.)
  const bool source_gone = source_watch_.Update(frames_.matched() > 0);
  if (end_frames_ < 0 && source_gone && pairer_.pending_frames() == 0 &&
      Clock::now() - last_frame_time_ > kSourceGone) {
    LOG_WARNING << "slam: the frame source left without announcing the end of its stream; "
                << "finishing with the " << frames_received_ << " frames received";
    stats_.input_cut_short = true;
    return true;
  }
  return false;
}

std::optional<PairedFrame> SlamShell::NextPaired(bool* end) {
  std::unique_lock<std::mutex> lock(mutex_);
  ReleaseHeld();  // expire held samples
  // Detector liveness from the matched writers of the detections topic.
  const int writers = detections_.matched();
  if (writers > 0) detector_writers_seen_ = writers;
  // A detector that announced FAILED is gone even if it never matched (e.g. no model): in
  // --deterministic mode slam would otherwise wait for its detections forever.
  pairer_.SetDetectorAlive(!detector_failed_ &&
                           (detector_done_ || !(detector_writers_seen_ > 0 && writers == 0)));
  std::optional<PairedFrame> paired = pairer_.Next(Clock::now());
  if (paired) return paired;
  if (stats_.frames_processed > 0 && !waiting_) {
    waiting_ = true;
    wait_since_ = Clock::now();
  }
  waited_with_frames_ = waited_with_frames_ || pairer_.pending_frames() > 0;
  if (StreamOver()) {
    *end = true;
    return std::nullopt;
  }
  const auto deadline = pairer_.NextDeadline();
  auto until = Clock::now() + std::chrono::milliseconds(20);
  if (deadline && *deadline < until) until = *deadline;
  cv_.wait_until(lock, until);
  return std::nullopt;
}

void SlamShell::LogBoxes(const PairedFrame& paired) {
  if (paired.detector_skipped) return;  // carries what the last detector frame had
  if (paired.detections_carried_forward) {
    if (!carrying_) {
      LOG_WARNING << "slam: no detections for frame " << paired.frame.stamp.ToString()
                  << " in time; filtering with the boxes of frame "
                  << paired.carried_from.ToString() << " carried forward";
    }
    carrying_ = true;
  } else if (paired.detections_missing) {
    if (carrying_ || !geometry_only_) {
      LOG_WARNING << "slam: no recent detections for frame " << paired.frame.stamp.ToString()
                  << "; geometry-only (no boxes)";
    }
    carrying_ = false;
    geometry_only_ = true;
  } else {
    carrying_ = false;
    geometry_only_ = false;
  }
}

void SlamShell::Process(const PairedFrame& paired) {
  const std::vector<Detection>* dets = paired.detections ? &*paired.detections : nullptr;
  double detection_ms = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const int64_t stamp = paired.frame.stamp.nanoseconds();
    auto it = inference_ms_.find(stamp);
    if (it != inference_ms_.end() && dets != nullptr) detection_ms = it->second;
    inference_ms_.erase(inference_ms_.begin(), inference_ms_.upper_bound(stamp));
  }
  const auto busy_begin = Clock::now();
  if (waiting_) {
    const double waited = std::chrono::duration<double>(busy_begin - wait_since_).count();
    (waited_with_frames_ ? stats_.wait_for_detections_s : stats_.wait_for_frames_s) += waited;
    waiting_ = false;
    waited_with_frames_ = false;
  }
  const SlamOutput out = core_.Process(paired.frame, dets, paired.detector_skipped);
  ++stats_.frames_processed;
  box_coverage_.Add(paired);
  stats_.frames_without_boxes = box_coverage_.frames_without_boxes();
  if (out.result.detections_carried) ++stats_.frames_carrying_boxes;
  if (out.result.world_from_cam) ++stats_.frames_tracked;
  LogBoxes(paired);
  msg::CameraPose pose = CameraPoseToMsg(out.result, paired.frame.seq, paired.detections_missing,
                                         paired.detections_carried_forward);
  if (dets != nullptr && options_.external_detections) pose.detection_ms(detection_ms);
  pose_writer_.Write(pose);
  PublishKeyframes(out.keyframes);
  stats_.busy_s += std::chrono::duration<double>(Clock::now() - busy_begin).count();
}

void SlamShell::Finish(const std::string& cut_short) {
  PublishKeyframes(core_.Finish());
  stats_.save_map_error = core_.save_map_error();
  trajectory_writer_.Write(TrajectoryToMsg(core_.Trajectory(), false));
  trajectory_writer_.Write(TrajectoryToMsg(core_.KeyframeTrajectory(), true));
  // Every keyframe message before DONE (the mapper ends on DONE).
  stats_.keyframe_messages_undelivered = keyframe_sender_.Finish(kKeyframeDeliveryTimeout);
  if (stats_.keyframe_messages_undelivered > 0) {
    LOG_WARNING << "slam: " << stats_.keyframe_messages_undelivered << " of "
                << stats_.keyframes_published << " keyframe messages were not delivered (a "
                << "reader of the keyframe topic did not acknowledge them, nor left, within "
                << kKeyframeDeliveryTimeout.count() / 1000 << " s): the map lacks them";
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stats_.pairing = pairer_.stats();
    stats_.detector_lost = stats_.pairing.lost_episodes > 0;
    stats_.detector_failed = detector_failed_;
    frame_gate_.Close();
    detection_gate_.Close();
    stats_.foreign_frames = frame_gate_.ignored();
    stats_.foreign_detections = detection_gate_.ignored();
    stats_.foreign_statuses = run_writers_.NumForeignStatuses();
  }
  status_.Write(
      ToMsg(ComponentStatus::Done(ComponentKind::kSlam, stats_.frames_processed, cut_short)));
  // Let reliable readers (mapper, recorder) get everything before the writers go away.
  keyframe_writer_.WaitForAcknowledgments(std::chrono::milliseconds(10000));
  trajectory_writer_.WaitForAcknowledgments(std::chrono::milliseconds(5000));
  status_.WaitForAcknowledgments(std::chrono::milliseconds(2000));
  const SlamStats& stats = stats_;
  LOG_INFO << "slam: " << stats.frames_processed << " frames (" << stats.frames_tracked
           << " tracked), " << stats.keyframes_published << " keyframe messages ("
           << stats.keyframes_published - stats.keyframe_pose_updates - stats.keyframes_removed
           << " new, " << stats.keyframe_pose_updates << " pose updates, "
           << stats.keyframes_removed << " removed); detections: " << stats.pairing.with_detections
           << " paired, " << stats.pairing.missing_detections << " missing (frames without their "
           << "own boxes: " << stats.pairing.carried_forward << " with boxes carried forward, "
           << stats.frames_without_boxes << " geometry-only), " << stats.frames_carrying_boxes
           << " skipped by the detector cadence (boxes carried), "
           << stats.pairing.dropped_detections << " arrived late (" << stats.pairing.late_used
           << " carried forward)" << (stats.detector_lost ? " (detector lost)" : "") << "; "
           << stats.pairing.dropped_frames << " frames dropped (arrived faster than tracked); busy "
           << stats.busy_s << " s, waited " << stats.wait_for_frames_s << " s for frames, "
           << stats.wait_for_detections_s << " s for detections";
  if (stats.foreign_frames + stats.foreign_detections > 0) {
    LOG_WARNING << "slam: "
                << IgnoredSamplesNote(std::to_string(stats.foreign_frames) + " frames and " +
                                      std::to_string(stats.foreign_detections) + " detections");
  }
  if (stats.foreign_statuses > 0) {
    LOG_WARNING << "slam: ignored " << stats.foreign_statuses
                << " end-of-stream / done statuses of participants that announced no component "
                   "of this run (not acted on)";
  }
}

SlamStats SlamShell::Run(const StopFlagPtr& stop) {
  ReadyAnnouncer announcer(ComponentKind::kSlam);
  map_announced_ = !core_.LoadedMapInfo();
  bool end = false;
  while (!stop->requested()) {
    started_.Poll(status_);
    bool detector_failed = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      detector_failed = detector_failed_;
    }
    // A detector that failed will not come: ready without it (geometry-only).
    announcer.Poll(status_,
                   frames_.matched() > 0 && (!pairing_options_.needs_detections ||
                                             detections_.matched() > 0 || detector_failed));
    if (announcer.done() && !map_announced_) AnnounceLoadedMap();
    const std::optional<PairedFrame> paired = NextPaired(&end);
    if (end) break;
    if (paired) Process(*paired);
  }
  // Stopped before the end of the stream (a signal, a failed peer): the consumers are told, so
  // that the frames it did not process count as missing, not as a complete run.
  std::string cut_short;
  if (!end)
    cut_short = stop->signal() != 0 ? "stopped by signal " + std::to_string(stop->signal()) +
                                          " before the end of the stream"
                                    : "stopped before the end of the stream";
  Finish(cut_short);
  return stats_;
}

}  // namespace

SlamStats RunSlam(std::shared_ptr<dds::Participant> participant,
                  const SlamComponentOptions& options, const StopFlagPtr& stop) {
  options.Check();
  SlamShell shell(std::move(participant), options);
  return shell.Run(stop);
}

}  // namespace dygslam
