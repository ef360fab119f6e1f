#include "components/mapper_component.h"

#include <atomic>
#include <chrono>
#include <deque>
#include <mutex>
#include <optional>
#include <thread>
#include <utility>
#include <vector>

#include "components/convert.h"
#include "components/dds/participant.h"
#include "components/dds/pubsub.h"
#include "components/protocol.h"
#include "components/status_reader.h"
#include "core/base/error.h"
#include "core/base/log.h"
#include "core/base/thread_setup.h"
#include "dygslam_msg/KeyframePubSubTypes.h"
#include "dygslam_msg/MapUpdatePubSubTypes.h"
#include "dygslam_msg/StreamStatusPubSubTypes.h"

namespace dygslam {

MapperStats RunMapper(std::shared_ptr<dds::Participant> participant, const MapperOptions& options,
                      const StopFlagPtr& stop) {
  MapperCore core(options);
  MapperStats stats;
  // Two stages: received keyframe messages pass the gate and are reduced at once, on the prepare
  // thread, to what the map keeps of them (the static cloud, ~30 KB, instead of ~2.4 MB of
  // images); the loop below applies them to the map (ray casting, rebuilds, map updates). A map
  // stage that falls behind the keyframe rate on a busy machine so queues clouds, not images:
  // with images, such a backlog grew the run by ~0.2 MB per frame until the end.
  struct Prepared {
    KeyframeData keyframe;  // images released once the cloud is extracted
    PinholeCamera camera;
    std::optional<StaticCloud> cloud;
  };
  BlockingQueue<Prepared> prepared;
  std::atomic<size_t> in_preparation{0};  // taken by the prepare thread, not yet in `prepared`
  std::atomic<size_t> bad_samples{0};
  std::atomic<bool> prepare_stop{false};
  BlockingQueue<std::pair<msg::Keyframe, WriterGuid>> queue;
  std::mutex mutex;
  bool slam_done = false;
  // Only keyframes of the writers announced by this run's slam (components/protocol.h); the ones
  // that arrive before the announcement wait for it (bounded).
  RunWriters writers;  // guarded by mutex
  WriterGate<msg::Keyframe> gate(&writers, DataTopic::kKeyframe, 256, std::chrono::seconds(5));
  std::deque<msg::Keyframe> admitted;  // guarded by mutex, in writer order

  dds::Writer<msg::MapUpdatePubSubType> updates(participant, dds::topics::kMapUpdate,
                                                dds::TopicKind::kMapUpdate);
  dds::Writer<msg::StreamStatusPubSubType> status(participant, dds::topics::kStreamStatus,
                                                  dds::TopicKind::kStreamStatus);
  // The status reader before the keyframe reader: a mapper that joins a running slam gets up to
  // 64 keyframes with images at once; its status endpoints match (and receive slam's
  // announcement) before that burst fills the transport.
  StatusReader status_reader(
      participant, ComponentKind::kMapper,
      [&](const ComponentStatus& s, const msg::StreamStatus& /*m*/, const WriterGuid& from) {
        std::lock_guard<std::mutex> lock(mutex);
        if (!writers.Announce(s, from)) return;  // a second frame source: not this run's
        if (s.source == ComponentKind::kSlam &&
            (s.event == StreamEvent::kComponentDone || s.event == StreamEvent::kFailed)) {
          slam_done = true;
        }
      });
  dds::Reader<msg::KeyframePubSubType> keyframes(participant, dds::topics::kKeyframe,
                                                 dds::TopicKind::kKeyframe,
                                                 [&](msg::Keyframe&& k, const WriterGuid& writer) {
                                                   queue.Push(std::make_pair(std::move(k), writer));
                                                 });
  StartedAnnouncer started(
      status,
      ComponentStatus::Started(ComponentKind::kMapper, {{DataTopic::kMapUpdate, updates.guid()}}));

  using Clock = std::chrono::steady_clock;
  std::optional<Clock::time_point> next_update_allowed;
  auto publish = [&] {
    if (!core.has_map()) return;
    const auto begin = Clock::now();
    core.Write();
    if (!options.map_path.empty()) ++stats.map_writes;
    updates.Write(core.MakeUpdate());
    ++stats.updates_published;
    const auto end = Clock::now();
    next_update_allowed = end + std::chrono::duration_cast<Clock::duration>(
                                    (end - begin) * (1.0 / options.max_update_share - 1.0));
  };

  size_t since_update = 0;
  // Since when no keyframe of this run arrived after slam's DONE (counting = true).
  bool idle_counting = false;
  Clock::time_point idle_since;
  WriterGoneWatch slam_gone(
      std::chrono::milliseconds(static_cast<int64_t>(options.writer_gone_s * 1000)));
  std::optional<std::chrono::steady_clock::time_point> flush_deadline;
  std::thread prepare_thread([&] {
    SetCurrentThreadName("map prepare");
    LowerCurrentThreadPriority();               // the map has no deadline: tracking goes first
    std::optional<PinholeCamera> cloud_camera;  // the map's camera: the first new keyframe's
    while (!prepare_stop) {
      std::optional<msg::Keyframe> sample;
      {
        // Received keyframes pass the gate; admitted ones are used in order.
        std::optional<std::pair<msg::Keyframe, WriterGuid>> received;
        {
          std::lock_guard<std::mutex> lock(mutex);
          if (admitted.empty()) {
            std::vector<msg::Keyframe> ready;
            gate.Release(Clock::now(), &ready);  // announced meanwhile, or expired
            admitted.insert(admitted.end(), std::make_move_iterator(ready.begin()),
                            std::make_move_iterator(ready.end()));
          }
        }
        if (!admitted.empty() ||
            (received = queue.Pop(std::chrono::milliseconds(gate.held() > 0 ? 5 : 50)))) {
          std::lock_guard<std::mutex> lock(mutex);
          if (received) {
            std::vector<msg::Keyframe> ready;
            gate.Offer(std::move(received->first), received->second, Clock::now(), &ready);
            admitted.insert(admitted.end(), std::make_move_iterator(ready.begin()),
                            std::make_move_iterator(ready.end()));
          }
          if (!admitted.empty()) {
            sample = std::move(admitted.front());
            admitted.pop_front();
          }  // else held until its writer is announced (or ignored): idle for what follows
        }
      }
      if (!sample) continue;
      ++in_preparation;
      try {
        Prepared p;
        p.keyframe = KeyframeFromMsg(*sample, &p.camera);
        if (ChangeOf(p.keyframe) == KeyframeChange::kNew && !p.keyframe.depth.empty()) {
          if (!cloud_camera) cloud_camera = p.camera;
          p.cloud = ExtractStaticCloud(p.keyframe, *cloud_camera, options.octomap);
          p.keyframe.rgb.release();
          p.keyframe.depth.release();
          p.keyframe.dynamic_mask.release();
        }
        prepared.Push(std::move(p));
      } catch (const InputError& e) {
        ++bad_samples;
        LOG_WARNING << "mapper: dropped keyframe " << sample->id() << ": " << e.what();
      }
      --in_preparation;
    }
  });
  ReadyAnnouncer announcer(ComponentKind::kMapper);
  // The map stage has no deadline: on a busy machine it takes the CPU time that the player,
  // the detector and slam leave, instead of delaying the poses (with the mapper at the same
  // priority, keyframe bursts in a crowd made poses late at the camera's rate).
  LowerCurrentThreadPriority();
  PauseWatch pause;
  while (true) {
    pause.Tick();
    started.Poll(status);
    announcer.Poll(status, keyframes.matched() > 0);
    if (stop->requested() && !flush_deadline) {
      // Stopping: slam publishes its last corrections as it stops; take them if it is there.
      flush_deadline =
          std::chrono::steady_clock::now() +
          std::chrono::milliseconds(static_cast<int64_t>(options.flush_timeout_s * 1000));
      if (keyframes.matched() == 0) *flush_deadline = std::chrono::steady_clock::now();
    }
    const bool writer_gone = slam_gone.Update(keyframes.matched() > 0);
    std::optional<Prepared> sample = prepared.Pop(std::chrono::milliseconds(50));
    if (!sample) {
      // slam gone without DONE, or this process paused while it left (keyframes it sent then
      // are lost). A slam that said DONE and left while the map stage still worked through its
      // backlog (the map stage runs at background priority) took nothing with it.
      bool done_said = false;
      {
        std::lock_guard<std::mutex> lock(mutex);
        done_said = slam_done;
      }
      if (writer_gone && (!done_said || pause.WasPaused())) {
        stats.input_cut_short = true;
        if (pause.WasPaused()) {
          LOG_WARNING << "mapper: this process was stopped (SIGSTOP) and continued, for about "
                      << pause.LongestSeconds() << " s, and slam left meanwhile; the keyframes "
                      << "it sent then are lost: writing the map without them";
        } else {
          LOG_WARNING << "mapper: slam's keyframe writer left " << options.writer_gone_s
                      << " s ago without announcing the end of its run; writing the map";
        }
        break;
      }
      std::lock_guard<std::mutex> lock(mutex);
      // slam's DONE is written after its last keyframe (and after waiting for acknowledgements);
      // order is only kept per writer, so allow a short grace period (300 ms without a keyframe
      // of this run) after DONE.
      // Still being received or prepared: not idle.
      if (queue.size() > 0 || in_preparation > 0) idle_counting = false;
      if (slam_done && !idle_counting && queue.size() == 0 && in_preparation == 0) {
        idle_counting = true;
        idle_since = Clock::now();
      }
      if (idle_counting && Clock::now() - idle_since > std::chrono::milliseconds(300)) {
        // slam done, but the frame source never ended its stream (killed, or failed): the map
        // lacks the rest. Its end is sent before slam's DONE, from another writer: by now it is
        // here unless it never came (2 s more allowed).
        if (writers.StreamUnfinished() && !stop->requested()) {
          if (Clock::now() - idle_since < std::chrono::milliseconds(2300)) continue;
          stats.input_cut_short = true;
          LOG_WARNING << "mapper: slam is done but the frame source never announced the end of "
                         "its stream (it was stopped or failed): the map lacks the frames it did "
                         "not play";
        }
        break;
      }
      if (flush_deadline &&
          (std::chrono::steady_clock::now() >= *flush_deadline || keyframes.matched() == 0)) {
        break;
      }
      continue;
    }
    idle_counting = false;
    try {
      const KeyframeData& k = sample->keyframe;
      core.Process(k, sample->camera, std::move(sample->cloud));
      ++stats.keyframes_received;
      if (!k.pose_update_only) ++since_update;
      if (options.update_every_keyframes > 0 &&
          since_update >= static_cast<size_t>(options.update_every_keyframes) && !flush_deadline &&
          (!next_update_allowed || Clock::now() >= *next_update_allowed)) {
        publish();
        since_update = 0;
      }
    } catch (const InputError& e) {
      ++stats.bad_samples;
      LOG_WARNING << "mapper: dropped keyframe " << sample->keyframe.id << ": " << e.what();
    }
  }
  prepare_stop = true;
  prepare_thread.join();
  stats.bad_samples += bad_samples;
  {
    std::lock_guard<std::mutex> lock(mutex);
    gate.Close();  // their writer never announced itself
    stats.foreign_samples = gate.ignored();
  }
  if (stats.foreign_samples > 0) {
    LOG_WARNING << "mapper: "
                << IgnoredSamplesNote(std::to_string(stats.foreign_samples) + " keyframes");
  }
  core.Finalize();
  publish();
  const bool full_written = core.has_map() && core.WriteFull();
  status.Write(ToMsg(ComponentStatus::Done(ComponentKind::kMapper, core.num_keyframes())));
  updates.WaitForAcknowledgments(std::chrono::milliseconds(3000));
  status.WaitForAcknowledgments(std::chrono::milliseconds(2000));
  LOG_INFO << "mapper: " << stats.keyframes_received << " keyframe messages ("
           << core.num_inserted() << " new, " << core.num_pose_updates() << " pose updates, "
           << core.num_removed() << " removed), " << core.num_keyframes() << " keyframes in the map"
           << (options.map_path.empty() || !core.has_map() ? ", no map written"
                                                           : ", written to " + options.map_path)
           << (full_written ? " and " + options.full_map_path : "");
  return stats;
}

}  // namespace dygslam
