#include "components/mapper_component.h"

#include <atomic>
#include <chrono>
#include <deque>
#include <exception>
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
namespace {

using Clock = std::chrono::steady_clock;

// A keyframe message reduced, on the prepare thread, to what the map keeps of it.
struct Prepared {
  KeyframeData keyframe;  // images released once the cloud is extracted
  PinholeCamera camera;
  std::optional<StaticCloud> cloud;
};

// The mapper's shell, in two stages: received keyframe messages pass the gate and are reduced at
// once, on the prepare thread, to what the map keeps of them (the static cloud, ~30 KB, instead of
// ~2.4 MB of images); the apply loop puts them into the map (ray casting, rebuilds, map updates).
// A map stage that falls behind the keyframe rate on a busy machine so queues clouds, not images:
// with images, such a backlog grew the run by ~0.2 MB per frame until the end.
class MapperShell {
 public:
  MapperShell(std::shared_ptr<dds::Participant> participant, const MapperOptions& options)
      : options_(options),
        core_(options),
        slam_gone_(std::chrono::milliseconds(static_cast<int64_t>(options.writer_gone_s * 1000))),
        updates_(participant, dds::topics::kMapUpdate, dds::TopicKind::kMapUpdate),
        status_(participant, dds::topics::kStreamStatus, dds::TopicKind::kStreamStatus),
        // The status reader before the keyframe reader: a mapper that joins a running slam gets
        // up to 64 keyframes with images at once; its status endpoints match (and receive slam's
        // announcement) before that burst fills the transport.
        status_reader_(participant, ComponentKind::kMapper,
                       [this](const ComponentStatus& s, const msg::StreamStatus& /*m*/,
                              const WriterGuid& from) { OnStatus(s, from); }),
        keyframes_(participant, dds::topics::kKeyframe, dds::TopicKind::kKeyframe,
                   [this](msg::Keyframe&& k, const WriterGuid& writer) {
                     queue_.Push(std::make_pair(std::move(k), writer));
                   }),
        started_(status_, ComponentStatus::Started(ComponentKind::kMapper,
                                                   {{DataTopic::kMapUpdate, updates_.guid()}})) {}

  MapperStats Run(const StopFlagPtr& stop);

 private:
  // What the apply loop does when no prepared keyframe came.
  enum class Idle { kWait, kEnd };
  // Why the apply loop returned: the map is complete (or cut short), or slam said it is done.
  enum class Loop { kEnded, kSlamDone };

  void OnStatus(const ComponentStatus& s, const WriterGuid& from);
  void PrepareLoop();
  // A thread running PrepareLoop; `background`: at lowered priority.
  std::thread StartPreparing(bool background);
  // Applies prepared keyframes until the map is complete or, with `until_slam_done`, until slam
  // has said that its run is done.
  Loop ApplyLoop(const StopFlagPtr& stop, bool until_slam_done);
  // The next admitted keyframe message (gate passed, in writer order), or none within ~50 ms.
  std::optional<msg::Keyframe> NextAdmitted();
  void Publish();
  void Apply(Prepared& sample, bool flushing);
  Idle AtIdle(bool writer_gone, const StopFlagPtr& stop);
  // The warning of a mapper paused while slam left (the keyframes sent meanwhile are lost).
  void WarnPausedWhileSlamLeft() const;
  void Finish(const StopFlagPtr& stop);

  const MapperOptions options_;
  MapperCore core_;
  MapperStats stats_;
  BlockingQueue<Prepared> prepared_;
  std::atomic<size_t> in_preparation_{0};  // taken by the prepare thread, not yet in prepared_
  std::atomic<size_t> bad_samples_{0};
  std::atomic<bool> prepare_stop_{false};
  std::optional<PinholeCamera> cloud_camera_;  // the map's camera: the first new keyframe's
  BlockingQueue<std::pair<msg::Keyframe, WriterGuid>> queue_;
  std::mutex mutex_;
  bool slam_done_ = false;  // guarded by mutex_
  // Only keyframes of the writers announced by this run's slam (components/protocol.h); the ones
  // that arrive before the announcement wait for it (bounded).
  RunWriters writers_;  // guarded by mutex_
  WriterGate<msg::Keyframe> gate_{&writers_, DataTopic::kKeyframe, 256, std::chrono::seconds(5)};
  std::deque<msg::Keyframe> admitted_;  // guarded by mutex_, in writer order
  std::optional<Clock::time_point> next_update_allowed_;
  size_t since_update_ = 0;
  // Since when no keyframe of this run arrived after slam's DONE (counting = true).
  bool idle_counting_ = false;
  Clock::time_point idle_since_;
  WriterGoneWatch slam_gone_;
  std::optional<Clock::time_point> flush_deadline_;
  PauseWatch pause_;
  ReadyAnnouncer announcer_{ComponentKind::kMapper};
  // The endpoints last: their listeners use the state above.
  dds::Writer<msg::MapUpdatePubSubType> updates_;
  dds::Writer<msg::StreamStatusPubSubType> status_;
  StatusReader status_reader_;
  dds::Reader<msg::KeyframePubSubType> keyframes_;
  StartedAnnouncer started_;
};

void MapperShell::OnStatus(const ComponentStatus& s, const WriterGuid& from) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!writers_.Announce(s, from)) return;  // a second frame source: not this run's
  if (s.source == ComponentKind::kSlam &&
      (s.event == StreamEvent::kComponentDone || s.event == StreamEvent::kFailed)) {
    slam_done_ = true;
  }
}

void MapperShell::Publish() {
  if (!core_.has_map()) return;
  const auto begin = Clock::now();
  core_.Write();
  if (!options_.map_path.empty()) ++stats_.map_writes;
  updates_.Write(core_.MakeUpdate());
  ++stats_.updates_published;
  const auto end = Clock::now();
  next_update_allowed_ = end + std::chrono::duration_cast<Clock::duration>(
                                   (end - begin) * (1.0 / options_.max_update_share - 1.0));
}

std::optional<msg::Keyframe> MapperShell::NextAdmitted() {
  // Received keyframes pass the gate; admitted ones are used in order.
  std::optional<std::pair<msg::Keyframe, WriterGuid>> received;
  bool have_admitted = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (admitted_.empty()) {
      std::vector<msg::Keyframe> ready;
      gate_.Release(Clock::now(), &ready);  // announced meanwhile, or expired
      admitted_.insert(admitted_.end(), std::make_move_iterator(ready.begin()),
                       std::make_move_iterator(ready.end()));
    }
    have_admitted = !admitted_.empty();
  }
  if (!have_admitted &&
      !(received = queue_.Pop(std::chrono::milliseconds(gate_.held() > 0 ? 5 : 50))))
    return std::nullopt;
  std::lock_guard<std::mutex> lock(mutex_);
  if (received) {
    std::vector<msg::Keyframe> ready;
    gate_.Offer(std::move(received->first), received->second, Clock::now(), &ready);
    admitted_.insert(admitted_.end(), std::make_move_iterator(ready.begin()),
                     std::make_move_iterator(ready.end()));
  }
  if (admitted_.empty()) return std::nullopt;  // held until its writer is announced (or ignored)
  std::optional<msg::Keyframe> sample = std::move(admitted_.front());
  admitted_.pop_front();
  return sample;
}

void MapperShell::PrepareLoop() {
  while (!prepare_stop_) {
    std::optional<msg::Keyframe> sample = NextAdmitted();
    if (!sample) continue;
    ++in_preparation_;
    try {
      Prepared p;
      p.keyframe = KeyframeFromMsg(*sample, &p.camera);
      if (ChangeOf(p.keyframe) == KeyframeChange::kNew && !p.keyframe.depth.empty()) {
        if (!cloud_camera_) cloud_camera_ = p.camera;
        p.cloud = ExtractStaticCloud(p.keyframe, *cloud_camera_, options_.octomap);
        p.keyframe.rgb.release();
        p.keyframe.depth.release();
        p.keyframe.dynamic_mask.release();
      }
      prepared_.Push(std::move(p));
    } catch (const InputError& e) {
      ++bad_samples_;
      LOG_WARNING << "mapper: dropped keyframe " << sample->id() << ": " << e.what();
    }
    --in_preparation_;
  }
}

void MapperShell::WarnPausedWhileSlamLeft() const {
  LOG_WARNING << "mapper: this process was stopped (SIGSTOP) and continued, for about "
              << pause_.LongestSeconds() << " s, and slam left meanwhile; the keyframes "
              << "it sent then are lost: writing the map without them";
}

MapperShell::Idle MapperShell::AtIdle(bool writer_gone, const StopFlagPtr& stop) {
  // slam gone without DONE, or this process paused while it left (keyframes it sent then are
  // lost). A slam that said DONE and left while the map stage still worked through its backlog
  // (the map stage runs at background priority) took nothing with it.
  bool done_said = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    done_said = slam_done_;
  }
  if (writer_gone && (!done_said || pause_.WasPaused())) {
    stats_.input_cut_short = true;
    if (pause_.WasPaused()) {
      WarnPausedWhileSlamLeft();
    } else {
      LOG_WARNING << "mapper: slam's keyframe writer left " << options_.writer_gone_s
                  << " s ago without announcing the end of its run; writing the map";
    }
    return Idle::kEnd;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  // slam's DONE is written after its last keyframe (and after waiting for acknowledgements);
  // order is only kept per writer, so allow a short grace period (300 ms without a keyframe
  // of this run) after DONE.
  // Still being received or prepared: not idle.
  if (queue_.size() > 0 || in_preparation_ > 0) idle_counting_ = false;
  if (slam_done_ && !idle_counting_ && queue_.size() == 0 && in_preparation_ == 0) {
    idle_counting_ = true;
    idle_since_ = Clock::now();
  }
  if (idle_counting_ && Clock::now() - idle_since_ > std::chrono::milliseconds(300)) {
    // slam done, but the frame source never ended its stream (killed, or failed): the map
    // lacks the rest. Its end is sent before slam's DONE, from another writer: by now it is
    // here unless it never came (2 s more allowed).
    if (writers_.StreamUnfinished() && !stop->requested()) {
      if (Clock::now() - idle_since_ < std::chrono::milliseconds(2300)) return Idle::kWait;
      stats_.input_cut_short = true;
      LOG_WARNING << "mapper: slam is done but the frame source never announced the end of "
                     "its stream (slam stopped before the end, or the frame source stopped or "
                     "failed): the map lacks the frames slam did not process";
    }
    return Idle::kEnd;
  }
  if (flush_deadline_ && (Clock::now() >= *flush_deadline_ || keyframes_.matched() == 0)) {
    // Stopped with slam out of sight and its end never received: slam left while this process
    // did not run. Paused: the keyframes slam sent meanwhile are lost (its leaving may not have
    // been seen: the stop came first). Never found at all: paused or starved from its start.
    // A stop by the user is an interrupted run, which the runner says.
    const bool never_found = stats_.keyframes_received == 0;
    if (!slam_done_ && keyframes_.matched() == 0 && (never_found || pause_.WasPaused())) {
      stats_.input_cut_short = true;
      if (pause_.WasPaused()) {
        WarnPausedWhileSlamLeft();
      } else {
        LOG_WARNING << "mapper: slam was never found: the map lacks its keyframes (this process "
                       "was paused or starved while slam ran, or the run stopped before slam "
                       "came)";
      }
    }
    return Idle::kEnd;
  }
  return Idle::kWait;
}

void MapperShell::Apply(Prepared& sample, bool flushing) {
  idle_counting_ = false;
  try {
    const KeyframeData& k = sample.keyframe;
    core_.Process(k, sample.camera, std::move(sample.cloud));
    ++stats_.keyframes_received;
    if (!k.pose_update_only) ++since_update_;
    if (options_.update_every_keyframes > 0 &&
        since_update_ >= static_cast<size_t>(options_.update_every_keyframes) && !flushing &&
        (!next_update_allowed_ || Clock::now() >= *next_update_allowed_)) {
      Publish();
      since_update_ = 0;
    }
  } catch (const InputError& e) {
    ++stats_.bad_samples;
    LOG_WARNING << "mapper: dropped keyframe " << sample.keyframe.id << ": " << e.what();
  }
}

void MapperShell::Finish(const StopFlagPtr& stop) {
  stats_.bad_samples += bad_samples_;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    gate_.Close();  // their writer never announced itself
    stats_.foreign_samples = gate_.ignored();
  }
  if (stats_.foreign_samples > 0) {
    LOG_WARNING << "mapper: "
                << IgnoredSamplesNote(std::to_string(stats_.foreign_samples) + " keyframes");
  }
  stats_.keyframe_messages_missed = static_cast<size_t>(keyframes_.losses().missed);
  if (stats_.keyframe_messages_missed > 0) {
    stats_.input_cut_short = true;
    LOG_WARNING << "mapper: " << stats_.keyframe_messages_missed << " keyframe messages of slam "
                << "never arrived (they left slam's history of the newest "
                << dds::kKeyframeHistoryDepth << " while this mapper was paused or unreachable "
                << "for longer than the DDS lease): the map lacks them";
  }
  core_.Finalize();
  Publish();
  const bool full_written = core_.has_map() && core_.WriteFull();
  bool slam_done = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    slam_done = slam_done_;
  }
  status_.Write(ToMsg(ComponentStatus::Done(ComponentKind::kMapper, core_.num_keyframes(),
                                            StoppedBeforeTheEnd(*stop, slam_done))));
  updates_.WaitForAcknowledgments(std::chrono::milliseconds(3000));
  status_.WaitForAcknowledgments(std::chrono::milliseconds(2000));
  LOG_INFO << "mapper: " << stats_.keyframes_received << " keyframe messages ("
           << core_.num_inserted() << " new, " << core_.num_pose_updates() << " pose updates, "
           << core_.num_removed() << " removed), " << core_.num_keyframes()
           << " keyframes in the map"
           << (options_.map_path.empty() || !core_.has_map() ? ", no map written"
                                                             : ", written to " + options_.map_path)
           << (full_written ? " and " + options_.full_map_path : "");
}

MapperShell::Loop MapperShell::ApplyLoop(const StopFlagPtr& stop, bool until_slam_done) {
  while (true) {
    pause_.Tick();
    started_.Poll(status_);
    announcer_.Poll(status_, keyframes_.matched() > 0);
    if (stop->requested() && !flush_deadline_) {
      // Stopping: slam publishes its last corrections as it stops; take them if it is there.
      flush_deadline_ = Clock::now() + std::chrono::milliseconds(
                                           static_cast<int64_t>(options_.flush_timeout_s * 1000));
      if (keyframes_.matched() == 0) *flush_deadline_ = Clock::now();
    }
    if (until_slam_done) {
      std::lock_guard<std::mutex> lock(mutex_);
      if (slam_done_) return Loop::kSlamDone;
    }
    const bool writer_gone = slam_gone_.Update(keyframes_.matched() > 0);
    std::optional<Prepared> sample = prepared_.Pop(std::chrono::milliseconds(50));
    if (!sample) {
      if (AtIdle(writer_gone, stop) == Idle::kEnd) return Loop::kEnded;
      continue;
    }
    Apply(*sample, flush_deadline_.has_value());
  }
}

std::thread MapperShell::StartPreparing(bool background) {
  prepare_stop_ = false;
  return std::thread([this, background] {
    SetCurrentThreadName("map prepare");
    if (background) LowerCurrentThreadPriority();
    PrepareLoop();
  });
}

MapperStats MapperShell::Run(const StopFlagPtr& stop) {
  // While slam runs, the map stage has no deadline: on a busy machine it takes the CPU time that
  // the player, the detector and slam leave, instead of delaying the poses (with the mapper at
  // the same priority, keyframe bursts in a crowd made poses late at the camera's rate). Once
  // slam's run is done nothing of the pipeline needs the CPU any more and the rest (the backlog,
  // the final map) is what the user waits for: it is finished at the process's own priority
  // (a lowered thread cannot raise itself again, so fresh threads of this one take over).
  // The prepare thread is stopped and joined however the apply loop ends (also by an exception,
  // which then reaches the caller).
  struct Preparing {
    MapperShell* shell;
    std::thread thread;
    void Stop() {
      shell->prepare_stop_ = true;
      if (thread.joinable()) thread.join();
    }
    ~Preparing() { Stop(); }
  } preparing{this, StartPreparing(/*background=*/true)};
  Loop ended = Loop::kEnded;
  std::exception_ptr error;
  std::thread background([&] {
    SetCurrentThreadName("map");
    LowerCurrentThreadPriority();
    try {
      ended = ApplyLoop(stop, /*until_slam_done=*/true);
    } catch (...) {
      error = std::current_exception();
    }
  });
  background.join();
  if (error) std::rethrow_exception(error);
  if (ended == Loop::kSlamDone) {
    preparing.Stop();
    preparing.thread = StartPreparing(/*background=*/false);
    ApplyLoop(stop, /*until_slam_done=*/false);
  }
  preparing.Stop();
  Finish(stop);
  return stats_;
}

}  // namespace

MapperStats RunMapper(std::shared_ptr<dds::Participant> participant, const MapperOptions& options,
                      const StopFlagPtr& stop) {
  MapperShell shell(std::move(participant), options);
  return shell.Run(stop);
}

}  // namespace dygslam
