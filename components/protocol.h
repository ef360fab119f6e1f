// The components' protocol on the status topic (dygslam/stream_status): which components there are
// (ComponentKind), what they announce (ComponentStatus: STARTED with the GUIDs of their data
// writers, READY, END_OF_STREAM, COMPONENT_DONE, FAILED with a reason, MAP_LOADED), how that maps
// onto msg::StreamStatus, and which data writers belong to the run (RunWriters, WriterGate).
// No DDS entities here (the message is the IDL type only): the shells read and write the topic.
//
// Wire form (msg::StreamStatus; kind values are stable, old peers understand 0..3):
//   kind 0 STARTED        source, num_frames (player: frames it will play), header.frame_id =
//                         "writers <topic>=<32 hex> ..." (topics: ToString(DataTopic))
//   kind 1 END_OF_STREAM  num_frames, header.seq = last seq
//   kind 2 COMPONENT_DONE num_frames (slam: frames processed; mapper: keyframes in the map)
//   kind 3 MAP_LOADED     num_frames = keyframes, header.frame_id = "map <16 hex checksum> <path>"
//   kind 4 READY          the component's inputs are matched (the player and the ROS 2 bridge
//                         wait for it before the first frame)
//   kind 5 FAILED         header.frame_id = the reason
//
// Writer ownership: on plain DDS any local process can join the run's partition
// and publish into it. Consumers accept data samples only from writers announced in a STARTED of
// the run's components; others are ignored and counted. A restarted component announces its new
// writers (STARTED) and is accepted again. DDS keeps order per writer only, so a sample can
// arrive before its writer's announcement: WriterGate holds such samples (bounded in count and
// time) until the announcement releases them or they expire (then they count as ignored). This
// guards against mistakes and casual injection, not against a participant that announces itself
// as a component: that is what DDS Security (--security) is for.
#pragma once

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "core/base/stop_signal.h"
#include "dygslam_msg/StreamStatus.h"

namespace dygslam {

// A DDS writer's GUID: 12-byte participant prefix, 4-byte entity id (what SampleInfo's
// publication_handle holds).
using WriterGuid = std::array<uint8_t, 16>;
std::string ToHex(const WriterGuid& guid);
// 32 hex digits -> GUID; nullopt when malformed.
std::optional<WriterGuid> WriterGuidFromHex(const std::string& hex);

enum class ComponentKind : uint8_t { kPlayer, kDetector, kSlam, kMapper, kRecorder, kRos2Bridge };
// "player", "detector", "slam", "mapper", "recorder", "ros2_bridge" (the status topic's `source`,
// the names of `dygslam component NAME`).
const char* ToString(ComponentKind kind);
std::optional<ComponentKind> ComponentKindFromName(const std::string& name);
// The pipeline components, "player | detector | slam | mapper | recorder" (for messages).
std::string PipelineComponentNames();

// What a component's failure means for a pipeline run (components/pipeline.cc).
// The frame source or slam: nothing can go on, the others are stopped (they flush).
bool FailureStopsPipeline(ComponentKind kind);
// Every component but the detector (slam carries boxes forward, then goes geometry-only).
bool FailureFailsRun(ComponentKind kind);
// The components that write the run's outputs (the run is over when they are done).
bool WritesOutputs(ComponentKind kind);
// A source of RgbdFrame samples (player, ROS 2 bridge).
bool IsFrameSource(ComponentKind kind);

enum class StreamEvent : uint8_t {
  kStarted = 0,
  kEndOfStream = 1,
  kComponentDone = 2,
  kMapLoaded = 3,
  kReady = 4,
  kFailed = 5
};
const char* ToString(StreamEvent event);

// The data topics whose writers a component announces.
enum class DataTopic : uint8_t {
  kFrames,
  kDetections,
  kCameraPose,
  kKeyframe,
  kTrajectory,
  kGroundTruth,
  kMapUpdate
};
// "frames", "detections", "camera_pose", "keyframe", "trajectory", "ground_truth", "map_update".
const char* ToString(DataTopic topic);

struct ComponentStatus {
  StreamEvent event = StreamEvent::kStarted;
  ComponentKind source = ComponentKind::kPlayer;
  // STARTED (player): frames it will play; END_OF_STREAM: frames published; COMPONENT_DONE: the
  // component's count; MAP_LOADED: keyframes of the map file.
  uint64_t num_frames = 0;
  uint64_t seq = 0;                         // END_OF_STREAM: seq of the last frame
  std::map<DataTopic, WriterGuid> writers;  // STARTED
  // FAILED: why; COMPONENT_DONE: why it ended before the end of its input ("" when it did not).
  std::string reason;
  uint64_t map_checksum = 0;  // MAP_LOADED
  std::string map_path;       // MAP_LOADED

  static ComponentStatus Started(ComponentKind source, std::map<DataTopic, WriterGuid> writers,
                                 uint64_t num_frames = 0);
  static ComponentStatus Ready(ComponentKind source);
  static ComponentStatus EndOfStream(ComponentKind source, uint64_t num_frames, uint64_t last_seq);
  static ComponentStatus Done(ComponentKind source, uint64_t num_frames = 0,
                              std::string cut_short = "");
  static ComponentStatus Failed(ComponentKind source, std::string reason);
  static ComponentStatus MapLoaded(ComponentKind source, uint64_t keyframes, uint64_t checksum,
                                   std::string path);
};

// ComponentStatus -> the message (header.stamp zero).
msg::StreamStatus ToMsg(const ComponentStatus& status);
// The message -> ComponentStatus. Throws InputError naming the field for a message this protocol
// does not understand: an unknown source or kind, a malformed writer list or map announcement.
ComponentStatus StatusFromMsg(const msg::StreamStatus& message);

// The data writers announced by the run's components (STARTED). Every STARTED adds its writers
// (a restarted component announces new ones; the old ones stay accepted: their samples still in
// flight are this run's).
//
// One frame source per run: a frame source (player, ROS 2 bridge) that announces itself while
// another one plays (its STARTED seen, its END_OF_STREAM or FAILED not yet) is a rival, e.g. a
// second `dygslam component player` started on the run's partition. Its writers are not accepted
// (its frames and ground truth count as ignored), and its later statuses (END_OF_STREAM, FAILED)
// are not the run's: Announce returns false for them, and the shell must not act on them.
// `status_writer`: the GUID of the status sample's writer (its participant prefix tells which
// participant sent it); without it a frame source's END_OF_STREAM / FAILED is always the run's.
//
// The end of a stream or of a component (END_OF_STREAM, DONE) is the run's only when its
// participant announced a component of the run (a STARTED) before: the same statuses from any
// other participant in the partition would end the run early. They are not the run's (false) and
// are counted (NumForeignStatuses). A FAILED is taken from any participant: a component that fails
// while it starts fails before its announcement.
class RunWriters {
 public:
  // False when `status` comes from a rival frame source (see above); true otherwise.
  bool Announce(const ComponentStatus& status,
                const std::optional<WriterGuid>& status_writer = std::nullopt);
  bool Owns(DataTopic topic, const WriterGuid& writer) const;
  // Writers announced for `topic` so far.
  size_t NumAnnounced(DataTopic topic) const;
  // Frame sources rejected as rivals so far (distinct participants).
  size_t NumRivals() const { return rivals_.size(); }
  // "player (participant 0f..12)" of the last rival, for messages; "" when there is none.
  const std::string& LastRival() const { return last_rival_; }
  // END_OF_STREAM / DONE statuses from participants that announced no component (see above).
  size_t NumForeignStatuses() const { return foreign_statuses_; }
  // The run's frame source announced itself (STARTED) and has not announced the end of its stream:
  // a slam that is done meanwhile finished with a stream cut short (its frame source killed or
  // failed), and the outputs lack its end.
  bool StreamUnfinished() const { return stream_started_ && !stream_ended_; }

 private:
  using Prefix = std::array<uint8_t, 12>;
  static Prefix PrefixOf(const WriterGuid& guid);
  std::map<DataTopic, std::set<WriterGuid>> writers_;
  std::optional<Prefix> frame_source_;  // the participant of the frame source that plays
  std::set<Prefix> rivals_;
  std::set<Prefix> announced_;  // participants that announced a component of the run
  size_t foreign_statuses_ = 0;
  std::string last_rival_;
  bool stream_started_ = false, stream_ended_ = false;
};

// Admits the samples of one data topic: those of announced writers pass (in arrival order per
// writer), those of writers not (yet) announced are held until an announcement releases them, at
// most `max_held` samples for at most `max_hold`; then they count as ignored. Not thread-safe:
// the shell calls it under its own lock.
template <class T>
class WriterGate {
 public:
  using Clock = std::chrono::steady_clock;

  WriterGate(const RunWriters* writers, DataTopic topic, size_t max_held,
             std::chrono::milliseconds max_hold)
      : writers_(writers), topic_(topic), max_held_(max_held), max_hold_(max_hold) {}

  // A sample arrived from `writer` at `now`; appends what may be used now to `ready` (held samples
  // of the same writer first, then this one).
  void Offer(T sample, const WriterGuid& writer, Clock::time_point now, std::vector<T>* ready) {
    Expire(now);
    if (writers_->Owns(topic_, writer)) {
      ReleaseWriter(writer, ready);
      ready->push_back(std::move(sample));
      return;
    }
    if (held_.size() >= max_held_) {
      ++ignored_;
      return;
    }
    held_.push_back(Held{std::move(sample), writer, now});
  }
  // After an announcement (and periodically): held samples of now-announced writers go to
  // `ready`; those older than max_hold are dropped and counted.
  void Release(Clock::time_point now, std::vector<T>* ready) {
    Expire(now);
    std::deque<Held> keep;
    for (Held& h : held_) {
      if (writers_->Owns(topic_, h.writer)) {
        ready->push_back(std::move(h.sample));
      } else {
        keep.push_back(std::move(h));
      }
    }
    held_.swap(keep);
  }
  // At the end: whatever is still held was never announced.
  void Close() {
    ignored_ += held_.size();
    held_.clear();
  }
  size_t held() const { return held_.size(); }
  size_t ignored() const { return ignored_; }

 private:
  struct Held {
    T sample;
    WriterGuid writer;
    Clock::time_point since;
  };
  void Expire(Clock::time_point now) {
    while (!held_.empty() && now - held_.front().since > max_hold_) {
      held_.pop_front();
      ++ignored_;
    }
  }
  void ReleaseWriter(const WriterGuid& writer, std::vector<T>* ready) {
    if (held_.empty()) return;
    std::deque<Held> keep;
    for (Held& h : held_) {
      if (h.writer == writer) {
        ready->push_back(std::move(h.sample));
      } else {
        keep.push_back(std::move(h));
      }
    }
    held_.swap(keep);
  }

  const RunWriters* writers_;
  DataTopic topic_;
  size_t max_held_;
  std::chrono::milliseconds max_hold_;
  std::deque<Held> held_;
  size_t ignored_ = 0;
};

// The words every component's summary uses for ignored samples: `counted` says what, e.g.
// "3 keyframes" -> "ignored 3 keyframes from writers outside this run (...)".
std::string IgnoredSamplesNote(const std::string& counted);

// Writes a component's STARTED, and writes it again whenever more status readers are matched
// than at the last Poll (a peer joined): the transient-local history does not always reach a
// reader that joins late (Fast DDS delivers it to late joiners unreliably, a limitation reported
// upstream), and a peer without the announcement ignores the component's samples. A repeated
// announcement changes nothing for a peer that has it (RunWriters takes it any number of
// times). Call Poll() from the component's loop while its stream goes on (a frame source stops
// after its END_OF_STREAM).
class StartedAnnouncer {
 public:
  // StatusWriter: anything with Write(const msg::StreamStatus&) and matched().
  template <class StatusWriter>
  StartedAnnouncer(StatusWriter& status, const ComponentStatus& started)
      : message_(ToMsg(started)) {
    status.Write(message_);
  }
  template <class StatusWriter>
  void Poll(StatusWriter& status) {
    const int matched = status.matched();
    if (matched > matched_) {
      status.Write(message_);
      ++repeats_;
    }
    matched_ = matched;
  }
  int repeats() const { return repeats_; }

 private:
  msg::StreamStatus message_;
  int matched_ = 0;
  int repeats_ = 0;
};

// Announces READY once the component's inputs are matched, or after `timeout` in any case. The
// player waits for READY of the components the pipeline runs before it publishes the first frame,
// so no component misses the start of the stream. Call Poll() from the component's loop.
class ReadyAnnouncer {
 public:
  explicit ReadyAnnouncer(ComponentKind kind,
                          std::chrono::milliseconds timeout = std::chrono::seconds(30))
      : kind_(kind), deadline_(std::chrono::steady_clock::now() + timeout) {}

  // StatusWriter: anything with Write(const msg::StreamStatus&).
  template <class StatusWriter>
  void Poll(StatusWriter& status, bool inputs_ready) {
    if (done_) return;
    if (!inputs_ready && std::chrono::steady_clock::now() < deadline_) return;
    status.Write(ToMsg(ComponentStatus::Ready(kind_)));
    done_ = true;
  }
  bool done() const { return done_; }

 private:
  ComponentKind kind_;
  std::chrono::steady_clock::time_point deadline_;
  bool done_ = false;
};

// A peer that leaves without announcing it (killed: its writers go with its participant's lease;
// or its announcement was missed): Update(matched) is true once the peer's writers were matched
// and have been unmatched for longer than `after`. Used by the components that would otherwise
// wait for the peer's END_OF_STREAM / COMPONENT_DONE for ever.
// TimesContinued(): core/base/stop_signal.h.

// The detail of a consumer's COMPONENT_DONE (recorder, mapper) when a stop signal ended it before
// slam's end of the run, "" otherwise: its peers (a hand-started player) tell an output that ends
// there from a complete one.
std::string StoppedBeforeTheEnd(const StopFlag& stop, bool slam_done);

// Whether this process was stopped and continued since the watch began, and the longest gap
// between two Tick()s of the calling loop (about how long it was stopped). A component stopped
// while its peer finished may have missed the peer's last samples and its end, which its warnings
// then say instead of blaming the peer.
class PauseWatch {
 public:
  using Clock = std::chrono::steady_clock;
  PauseWatch() : continued_at_start_(TimesContinued()) {}
  void Tick(Clock::time_point now = Clock::now()) {
    if (last_) longest_ = std::max(longest_, now - *last_);
    last_ = now;
  }
  double LongestSeconds() const { return std::chrono::duration<double>(longest_).count(); }
  bool WasPaused() const { return TimesContinued() > continued_at_start_; }

 private:
  unsigned continued_at_start_;
  std::optional<Clock::time_point> last_;
  Clock::duration longest_{0};
};

// When this process was stopped and continued (the whole run suspended with Ctrl-Z, a laptop
// asleep), its peers' leases may have run out meanwhile: their writers look gone until discovery
// finds them again (a participant announces itself every few seconds). A peer unmatched then is
// given kResumeGrace from the resumption before it counts as gone.
class WriterGoneWatch {
 public:
  using Clock = std::chrono::steady_clock;
  static constexpr std::chrono::seconds kResumeGrace{12};
  explicit WriterGoneWatch(Clock::duration after)
      : after_(after), continued_seen_(TimesContinued()) {}
  // The peer is known to have been there (it announced READY) although no Update saw it matched:
  // it may have left before the first Update.
  void Seen() { seen_ = true; }
  bool Update(bool matched, Clock::time_point now = Clock::now()) {
    if (const unsigned continued = TimesContinued(); continued != continued_seen_) {
      continued_seen_ = continued;
      grace_until_ = now + kResumeGrace;
      unmatched_since_.reset();
    }
    seen_ = seen_ || matched;
    if (matched || !seen_) {
      unmatched_since_.reset();
      return false;
    }
    if (!unmatched_since_) unmatched_since_ = now;
    return now - *unmatched_since_ > after_ && (!grace_until_ || now > *grace_until_);
  }

 private:
  Clock::duration after_;
  unsigned continued_seen_;
  bool seen_ = false;
  std::optional<Clock::time_point> unmatched_since_, grace_until_;
};

}  // namespace dygslam
