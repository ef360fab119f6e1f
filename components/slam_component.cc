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
}  // namespace

SlamStats RunSlam(std::shared_ptr<dds::Participant> participant,
                  const SlamComponentOptions& options, const StopFlagPtr& stop) {
  using Clock = FramePairer::Clock;
  options.Check();
  SlamCore core(options);
  SlamStats stats;

  PairingOptions pairing_options;
  pairing_options.needs_detections = options.NeedsDetections();
  pairing_options.deterministic = options.system.deterministic;
  pairing_options.max_wait = options.detection_wait;
  pairing_options.lost_after_misses = options.detector_lost_after_misses;
  pairing_options.carry_forward_max_frames = options.carry_forward_max_frames;
  pairing_options.detection_every_n_frames = options.system.detection_every_n_frames;

  std::mutex mutex;
  std::condition_variable cv;
  FramePairer pairer(pairing_options);  // guarded by mutex
  int64_t end_frames = -1;
  size_t frames_received = 0;
  Clock::time_point last_frame_time = Clock::now();
  bool frame_source_seen = false;  // a frame writer was matched
  int detector_writers_seen = 0;
  std::map<int64_t, double> inference_ms;  // detector component's time per frame stamp (ns)
  bool detector_done = false;    // the detector announced COMPONENT_DONE (finished, not lost)
  bool detector_failed = false;  // the detector announced FAILED: no detections will come
  bool carrying = false;         // the previous frame ran with boxes carried forward (log once)
  bool geometry_only = false;    // the previous frame ran without any boxes (log once)

  dds::Writer<msg::CameraPosePubSubType> pose_writer(participant, dds::topics::kCameraPose,
                                                     dds::TopicKind::kCameraPose);
  dds::Writer<msg::KeyframePubSubType> keyframe_writer(participant, dds::topics::kKeyframe,
                                                       dds::TopicKind::kKeyframe);
  dds::Writer<msg::TrajectoryPubSubType> trajectory_writer(participant, dds::topics::kTrajectory,
                                                           dds::TopicKind::kTrajectory);
  dds::Writer<msg::StreamStatusPubSubType> status(participant, dds::topics::kStreamStatus,
                                                  dds::TopicKind::kStreamStatus);
  // Frames and detections only from writers announced by this run's components (STARTED, see
  // components/protocol.h); early ones wait briefly for their writer's announcement.
  RunWriters run_writers;  // guarded by mutex
  WriterGate<msg::RgbdFrame> frame_gate(&run_writers, DataTopic::kFrames, kMaxHeldFrames, kMaxHold);
  WriterGate<msg::Detections> detection_gate(&run_writers, DataTopic::kDetections,
                                             kMaxHeldDetections, kMaxHold);
  // Admitted samples -> the pairer, in the order the gates admit them (called under `mutex`).
  auto use_frames = [&](std::vector<msg::RgbdFrame>* ready) {
    for (msg::RgbdFrame& sample : *ready) {
      try {
        pairer.AddFrame(RgbdFrameFromMsg(sample), Clock::now());
        ++frames_received;
        last_frame_time = Clock::now();
      } catch (const InputError& e) {
        ++stats.bad_samples;
        LOG_WARNING << "slam: dropped frame seq " << sample.header().seq() << ": " << e.what();
      }
    }
    ready->clear();
  };
  auto use_detections = [&](std::vector<msg::Detections>* ready) {
    for (msg::Detections& sample : *ready) {
      try {
        std::vector<Detection> dets = DetectionsFromMsg(sample);
        const Timestamp stamp = TimeFromMsg(sample.header().stamp(), "Detections.header.stamp");
        inference_ms[stamp.nanoseconds()] = sample.inference_ms();
        pairer.AddDetections(stamp, std::move(dets));
      } catch (const InputError& e) {
        LOG_WARNING << "slam: dropped detections seq " << sample.header().seq() << ": " << e.what();
      }
    }
    ready->clear();
  };
  // Held samples whose writer was announced meanwhile are used; expired ones counted (under
  // `mutex`).
  auto release_held = [&] {
    std::vector<msg::RgbdFrame> ready_frames;
    std::vector<msg::Detections> ready_detections;
    frame_gate.Release(Clock::now(), &ready_frames);
    detection_gate.Release(Clock::now(), &ready_detections);
    use_frames(&ready_frames);
    use_detections(&ready_detections);
  };
  dds::Reader<msg::RgbdFramePubSubType> frames(
      participant, dds::topics::kRgbdFrame, dds::TopicKind::kRgbdFrame,
      [&](msg::RgbdFrame&& sample, const WriterGuid& writer) {
        {
          std::lock_guard<std::mutex> lock(mutex);
          std::vector<msg::RgbdFrame> ready;
          frame_gate.Offer(std::move(sample), writer, Clock::now(), &ready);
          use_frames(&ready);
        }
        cv.notify_all();
      });
  dds::Reader<msg::DetectionsPubSubType> detections(
      participant, dds::topics::kDetections, dds::TopicKind::kDetections,
      [&](msg::Detections&& sample, const WriterGuid& writer) {
        {
          std::lock_guard<std::mutex> lock(mutex);
          std::vector<msg::Detections> ready;
          detection_gate.Offer(std::move(sample), writer, Clock::now(), &ready);
          use_detections(&ready);
        }
        cv.notify_all();
      });
  RepeatedWarning rival_warning;  // a rival announces itself again as peers join
  StatusReader status_reader(
      participant, ComponentKind::kSlam,
      [&](const ComponentStatus& s, const msg::StreamStatus& m, const WriterGuid& from) {
        {
          std::lock_guard<std::mutex> lock(mutex);
          if (!run_writers.Announce(s, from)) {
            // A second frame source on the run's partition: its frames and its end of stream
            // are not this run's (its frames count as ignored in the summary).
            if (s.event == StreamEvent::kStarted && rival_warning.Say()) {
              LOG_WARNING << "slam: rejected a second frame source on this run's partition: "
                          << run_writers.LastRival() << " announced itself while the run's "
                          << "frame source plays; its frames are ignored (give each run its own "
                          << "--partition)";
            }
            return;
          }
          if (s.event == StreamEvent::kEndOfStream && IsFrameSource(s.source)) {
            end_frames = StreamFrameCountFromMsg(m);
            if (end_frames == std::numeric_limits<int64_t>::max()) {
              LOG_WARNING << "slam: END_OF_STREAM announces " << m.num_frames()
                          << " frames; finishing when the stream goes idle";
            }
          }
          if (s.event == StreamEvent::kFailed && IsFrameSource(s.source)) {
            // No more frames will come: finish with the ones that arrived.
            LOG_WARNING << "slam: the frame source (" << ToString(s.source)
                        << ") failed: " << s.reason;
            end_frames = static_cast<int64_t>(frames_received + stats.bad_samples);
          }
          if (s.event == StreamEvent::kComponentDone && s.source == ComponentKind::kDetector) {
            detector_done = true;
          }
          if (s.event == StreamEvent::kFailed && s.source == ComponentKind::kDetector) {
            LOG_WARNING << "slam: the detector failed: " << s.reason;
            detector_failed = true;
          }
          if (s.event == StreamEvent::kStarted) release_held();
        }
        cv.notify_all();
      });
  StartedAnnouncer started(
      status, ComponentStatus::Started(ComponentKind::kSlam,
                                       {{DataTopic::kCameraPose, pose_writer.guid()},
                                        {DataTopic::kKeyframe, keyframe_writer.guid()},
                                        {DataTopic::kTrajectory, trajectory_writer.guid()}}));

  auto publish_keyframes = [&](const std::vector<KeyframeData>& keyframes) {
    for (const KeyframeData& k : keyframes) {
      if (!keyframe_writer.Write(KeyframeToMsg(k, core.camera()))) {
        // The bounded history was full of samples a reader had not acknowledged for
        // max_blocking_time (1 s): that reader misses this message.
        LOG_WARNING << "slam: keyframe message " << k.id << " not accepted by the writer";
      }
      ++stats.keyframes_published;
      if (k.removed) {
        ++stats.keyframes_removed;
      } else if (k.pose_update_only) {
        ++stats.keyframe_pose_updates;
      }
    }
  };

  ReadyAnnouncer announcer(ComponentKind::kSlam);
  bool waiting = false;  // after the first frame: no frame ready since wait_since
  Clock::time_point wait_since = Clock::now();
  bool waited_with_frames = false;  // a frame was pending during that wait
  bool map_announced = !core.LoadedMapInfo();
  while (!stop->requested()) {
    started.Poll(status);
    announcer.Poll(status, frames.matched() > 0 &&
                               (!pairing_options.needs_detections || detections.matched() > 0));
    if (announcer.done() && !map_announced) {
      // The map this slam starts from, after READY so the readers are matched.
      const MapFileInfo info = *core.LoadedMapInfo();
      status.Write(ToMsg(ComponentStatus::MapLoaded(ComponentKind::kSlam, info.keyframes,
                                                    info.checksum, options.system.load_map)));
      LOG_INFO << "slam: started from map file " << options.system.load_map << " ("
               << DescribeMapFile(info) << ")"
               << (options.system.localization ? ", localization" : "");
      map_announced = true;
    }
    std::optional<PairedFrame> paired;
    {
      std::unique_lock<std::mutex> lock(mutex);
      release_held();  // expire held samples
      // Detector liveness from the matched writers of the detections topic.
      const int writers = detections.matched();
      if (writers > 0) detector_writers_seen = writers;
      // A detector that announced FAILED is gone even if it never matched (e.g. no model): in
      // --deterministic mode slam would otherwise wait for its detections forever.
      pairer.SetDetectorAlive(!detector_failed &&
                              (detector_done || !(detector_writers_seen > 0 && writers == 0)));
      paired = pairer.Next(Clock::now());
      if (!paired) {
        if (stats.frames_processed > 0 && !waiting) {
          waiting = true;
          wait_since = Clock::now();
        }
        waited_with_frames = waited_with_frames || pairer.pending_frames() > 0;
        const bool all_in = end_frames >= 0 &&
                            static_cast<int64_t>(frames_received + stats.bad_samples) >= end_frames;
        const bool stale_end = end_frames >= 0 && pairer.pending_frames() == 0 &&
                               Clock::now() - last_frame_time > std::chrono::seconds(3);
        if ((all_in && pairer.pending_frames() == 0) || stale_end) break;
        // A frame source that left without its END_OF_STREAM (killed, or the announcement lost)
        // would leave slam waiting for ever: once its writer is gone and nothing arrived for
        // kSourceGone, finish with the frames that came.
        const int frame_writers = frames.matched();
        frame_source_seen = frame_source_seen || frame_writers > 0;
        if (end_frames < 0 && frame_source_seen && frame_writers == 0 &&
            pairer.pending_frames() == 0 && Clock::now() - last_frame_time > kSourceGone) {
          LOG_WARNING << "slam: the frame source left without announcing the end of its stream; "
                      << "finishing with the " << frames_received << " frames received";
          stats.input_cut_short = true;
          break;
        }
        const auto deadline = pairer.NextDeadline();
        auto until = Clock::now() + std::chrono::milliseconds(20);
        if (deadline && *deadline < until) until = *deadline;
        cv.wait_until(lock, until);
        continue;
      }
    }
    const std::vector<Detection>* dets = paired->detections ? &*paired->detections : nullptr;
    double detection_ms = 0;
    {
      std::lock_guard<std::mutex> lock(mutex);
      const int64_t stamp = paired->frame.stamp.nanoseconds();
      auto it = inference_ms.find(stamp);
      if (it != inference_ms.end() && dets != nullptr) detection_ms = it->second;
      inference_ms.erase(inference_ms.begin(), inference_ms.upper_bound(stamp));
    }
    const auto busy_begin = Clock::now();
    if (waiting) {
      const double waited = std::chrono::duration<double>(busy_begin - wait_since).count();
      (waited_with_frames ? stats.wait_for_detections_s : stats.wait_for_frames_s) += waited;
      waiting = false;
      waited_with_frames = false;
    }
    const SlamOutput out = core.Process(paired->frame, dets, paired->detector_skipped);
    ++stats.frames_processed;
    if (out.result.detections_carried) ++stats.frames_carrying_boxes;
    if (out.result.world_from_cam) ++stats.frames_tracked;
    if (paired->detections_carried_forward) {
      if (!carrying) {
        LOG_WARNING << "slam: no detections for frame " << paired->frame.stamp.ToString()
                    << " in time; filtering with the boxes of frame "
                    << paired->carried_from.ToString() << " carried forward";
      }
      carrying = true;
    } else if (paired->detections_missing) {
      if (carrying || !geometry_only) {
        LOG_WARNING << "slam: no recent detections for frame " << paired->frame.stamp.ToString()
                    << "; geometry-only (no boxes)";
      }
      carrying = false;
      geometry_only = true;
    } else {
      carrying = false;
      geometry_only = false;
    }
    msg::CameraPose pose =
        CameraPoseToMsg(out.result, paired->frame.seq, paired->detections_missing,
                        paired->detections_carried_forward);
    if (dets != nullptr && options.external_detections) pose.detection_ms(detection_ms);
    pose_writer.Write(pose);
    publish_keyframes(out.keyframes);
    stats.busy_s += std::chrono::duration<double>(Clock::now() - busy_begin).count();
  }

  publish_keyframes(core.Finish());
  stats.save_map_error = core.save_map_error();
  trajectory_writer.Write(TrajectoryToMsg(core.Trajectory(), false));
  trajectory_writer.Write(TrajectoryToMsg(core.KeyframeTrajectory(), true));
  {
    std::lock_guard<std::mutex> lock(mutex);
    stats.pairing = pairer.stats();
    stats.detector_lost = stats.pairing.lost_episodes > 0;
    frame_gate.Close();
    detection_gate.Close();
    stats.foreign_frames = frame_gate.ignored();
    stats.foreign_detections = detection_gate.ignored();
    stats.foreign_statuses = run_writers.NumForeignStatuses();
  }
  status.Write(ToMsg(ComponentStatus::Done(ComponentKind::kSlam, stats.frames_processed)));
  // Let reliable readers (mapper, recorder) get everything before the writers go away.
  keyframe_writer.WaitForAcknowledgments(std::chrono::milliseconds(10000));
  trajectory_writer.WaitForAcknowledgments(std::chrono::milliseconds(5000));
  status.WaitForAcknowledgments(std::chrono::milliseconds(2000));
  LOG_INFO << "slam: " << stats.frames_processed << " frames (" << stats.frames_tracked
           << " tracked), " << stats.keyframes_published << " keyframe messages ("
           << stats.keyframes_published - stats.keyframe_pose_updates - stats.keyframes_removed
           << " new, " << stats.keyframe_pose_updates << " pose updates, "
           << stats.keyframes_removed << " removed); detections: " << stats.pairing.with_detections
           << " paired, " << stats.pairing.missing_detections << " missing (frames without their "
           << "own boxes: " << stats.pairing.carried_forward << " with boxes carried forward, "
           << stats.pairing.missing_detections - stats.pairing.carried_forward
           << " geometry-only), " << stats.frames_carrying_boxes
           << " skipped by the detector cadence (boxes carried), "
           << stats.pairing.dropped_detections << " arrived late (" << stats.pairing.late_used
           << " carried forward)" << (stats.detector_lost ? " (detector lost)" : "") << "; busy "
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
  return stats;
}

}  // namespace dygslam
