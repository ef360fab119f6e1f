#include "components/player.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <thread>
#include <vector>

#include "components/dds/participant.h"
#include "components/dds/pubsub.h"
#include "components/status_reader.h"
#include "core/base/error.h"
#include "core/base/log.h"
#include "core/io/trajectory_io.h"
#include "dygslam_msg/CameraPosePubSubTypes.h"
#include "dygslam_msg/GroundTruthPubSubTypes.h"
#include "dygslam_msg/RgbdFramePubSubTypes.h"
#include "dygslam_msg/StreamStatusPubSubTypes.h"

namespace dygslam {
namespace {
// A pause longer than this (the DDS participant lease, 20 s, with a margin) makes the peers drop
// each other; they find each other again within moments of the continue.
constexpr std::chrono::seconds kPauseOverLease{18};

// Poses of another frame source's frames (a second of them at 30 Hz) with none for this player's:
// the run's consumers took the other source, and this player's frames are refused.
constexpr size_t kRefusedAfterForeignPoses = 30;

using Clock = std::chrono::steady_clock;

// How long the pipeline has kept a frame without a result at `now`: since the last result or
// since the oldest frame still out (`sent`: send times by sequence number) was sent, whichever is
// later; 0 with no frame out or before the first result (start-up is not a stall).
std::chrono::duration<double> WaitWithFrameOut(Clock::time_point now,
                                               const std::optional<Clock::time_point>& last_result,
                                               const std::map<uint64_t, Clock::time_point>& sent) {
  if (!last_result || sent.empty()) return std::chrono::duration<double>(0);
  return now - std::max(*last_result, sent.begin()->second);
}

}  // namespace

void PlayerOptions::Check() const {
  DYGSLAM_CHECK_OPTION(!dataset_dir.empty(), "player.dataset_dir");
  camera.Check();
  DYGSLAM_CHECK_OPTION(depth_scale > 0 && std::isfinite(depth_scale), "player.depth_scale");
  DYGSLAM_CHECK_OPTION(rate >= 0 && std::isfinite(rate), "player.rate");
  DYGSLAM_CHECK_OPTION(window >= 0 && window < dds::kFrameHistoryDepth, "player.window");
  DYGSLAM_CHECK_OPTION(ack_timeout_s > 0, "player.ack_timeout_s");
  DYGSLAM_CHECK_OPTION(wait_for_readers_s >= 0, "player.wait_for_readers_s");
  DYGSLAM_CHECK_OPTION(expected_readers >= 0, "player.expected_readers");
  DYGSLAM_CHECK_OPTION(loop_minutes >= 0 && std::isfinite(loop_minutes), "player.loop_minutes");
}

DatasetPlayer::DatasetPlayer(const PlayerOptions& options)
    : options_(options), dataset_(RgbdDataset::Open(options.dataset_dir)) {
  options_.Check();
  const size_t last = options.last_entry == 0
                          ? dataset_.num_rgb_entries()
                          : std::min(options.last_entry, dataset_.num_rgb_entries());
  for (size_t k = options.first_entry; k < last; ++k) {
    if (const auto index = dataset_.FrameForRgbEntry(k)) indices_.push_back(*index);
  }
}

RgbdFrameData DatasetPlayer::Frame(size_t i) const {
  if (i >= num_frames()) throw std::out_of_range("DatasetPlayer::Frame: index out of range");
  const size_t k = indices_[i];
  RgbdFrameData f;
  f.stamp = dataset_.frame(k).rgb_stamp;
  f.seq = i;
  f.frame_id = "camera";
  f.camera = options_.camera;
  f.depth_scale = options_.depth_scale;
  f.rgb = dataset_.LoadRgb(k, options_.camera.width, options_.camera.height);
  f.depth = dataset_.LoadDepth(k, options_.camera.width, options_.camera.height);
  return f;
}

Timestamp DatasetPlayer::Stamp(size_t i) const {
  if (i >= num_frames()) throw std::out_of_range("DatasetPlayer::Stamp: index out of range");
  return dataset_.frame(indices_[i]).rgb_stamp;
}

std::vector<StampedPose> DatasetPlayer::GroundTruth() const {
  if (!dataset_.has_groundtruth() || num_frames() == 0) return {};
  const Timestamp first = dataset_.frame(indices_.front()).rgb_stamp;
  const Timestamp last = dataset_.frame(indices_.back()).rgb_stamp;
  const Timestamp margin = Timestamp::FromNanoseconds(100000000);  // 0.1 s
  std::vector<StampedPose> all;
  try {
    all = ReadTumTrajectory(dataset_.groundtruth_path());
  } catch (const InputError& e) {
    // Ground truth only scores the run: a malformed file does not stop the frames (`dygslam run`
    // has warned about it before starting the pipeline).
    LOG_WARNING << "player: ground truth not published: " << e.what();
    return {};
  }
  std::vector<StampedPose> result;
  for (const StampedPose& p : all) {
    if (p.stamp.nanoseconds() >= first.nanoseconds() - margin.nanoseconds() &&
        p.stamp.nanoseconds() <= last.nanoseconds() + margin.nanoseconds()) {
      result.push_back(p);
    }
  }
  return result;
}

LatencyReservoir::LatencyReservoir(size_t capacity) : capacity_(std::max<size_t>(capacity, 1)) {
  sample_.reserve(std::min<size_t>(capacity_, 1024));
}

void LatencyReservoir::Add(double value) {
  ++count_;
  if (sample_.size() < capacity_) {
    sample_.push_back(value);
    return;
  }
  // Algorithm R: the k-th value replaces a random kept one with probability capacity / k.
  state_ ^= state_ >> 12;
  state_ ^= state_ << 25;
  state_ ^= state_ >> 27;
  const uint64_t r = (state_ * 0x2545f4914f6cdd1dULL) % count_;
  if (r < capacity_) sample_[r] = value;
}

double LatencyReservoir::Quantile(double q) const {
  if (sample_.empty()) return 0;
  std::vector<double> sorted = sample_;
  std::sort(sorted.begin(), sorted.end());
  const size_t index = std::min(sorted.size() - 1, static_cast<size_t>(q * sorted.size() + 1e-9));
  return sorted[index];
}

namespace {

// The player's shell: publishes the dataset's frames (paced at the camera's rate, or as fast as
// the window of unacknowledged frames allows), reads the poses back for the window and for the
// latency, and ends after slam's DONE.
class PlayerShell {
 public:
  PlayerShell(std::shared_ptr<dds::Participant> participant, const PlayerOptions& options)
      : options_(options),
        player_(options),
        begin_(Clock::now()),
        start_(begin_),
        continued_at_last_pose_(TimesContinued()),
        continued_at_last_frame_(TimesContinued()),
        late_after_ms_(LateAfterMs()),
        frames_(participant, dds::topics::kRgbdFrame, dds::TopicKind::kRgbdFrame),
        gt_writer_(participant, dds::topics::kGroundTruth, dds::TopicKind::kGroundTruth),
        status_(participant, dds::topics::kStreamStatus, dds::TopicKind::kStreamStatus),
        poses_(participant, dds::topics::kCameraPose, dds::TopicKind::kCameraPose,
               [this](msg::CameraPose&& pose, const WriterGuid& writer) { OnPose(pose, writer); }),
        status_reader_(participant, ComponentKind::kPlayer,
                       [this](const ComponentStatus& s, const msg::StreamStatus& /*m*/,
                              const WriterGuid& from) { OnStatus(s, from); }),
        // Who we are and which writers are ours (the consumers accept frames and ground truth
        // only from announced writers; components/protocol.h).
        started_(status_, ComponentStatus::Started(ComponentKind::kPlayer,
                                                   {{DataTopic::kFrames, frames_.guid()},
                                                    {DataTopic::kGroundTruth, gt_writer_.guid()}},
                                                   player_.num_frames())) {}

  PlayerStats Run(const StopFlagPtr& stop);

 private:
  // Paced runs: the frame period at the played rate, from the stamps; later poses are late.
  double LateAfterMs() const;
  void OnPose(const msg::CameraPose& pose, const WriterGuid& writer);
  void OnStatus(const ComponentStatus& s, const WriterGuid& from);
  // A slam that was there and left without COMPONENT_DONE (killed, or its DONE lost): its pose
  // writer unmatched for 5 s. Then no acknowledgement and no DONE will come: stop waiting.
  bool SlamGone() {
    slam_gone_reported_ = slam_gone_reported_ || slam_watch_.Update(poses_.matched() > 0);
    return slam_gone_reported_;
  }
  // After slam's end: waits for the DONE of the run's recorder or mapper (`kind`) when the run has
  // one (waited for, and READY); false when it left without (killed: the run's trajectory is not
  // written, its map lacks the rest): not present for 5 s.
  bool ConsumerFinished(ComponentKind kind, const StopFlagPtr& stop);
  void WaitForPeers(const StopFlagPtr& stop);
  // The frame readers this player waits for (those that announced FAILED are not).
  int ExpectedReaders();
  // After this process was stopped and continued: peers whose lease ran out meanwhile are dropped
  // and found again within moments, and frames sent before that are lost. Waits (at most
  // WriterGoneWatch::kResumeGrace) until the frame readers are matched again.
  // `paused`: how long the replay stood still (longer than kPauseOverLease: the leases ran out).
  void AwaitReadersAfterResume(Clock::duration paused, const StopFlagPtr& stop);
  void PlayFrames(const StopFlagPtr& stop);
  // Paced runs: waits until frame `n` is due; false when stopped meanwhile.
  bool WaitUntilDue(size_t n, const RgbdFrameData& frame, const StopFlagPtr& stop);
  // With a window: waits for the acknowledgement of frame n - window (bounded).
  void WaitForWindow(size_t n, const StopFlagPtr& stop);
  void EndStream(const StopFlagPtr& stop);
  // Says that the run's consumers take another frame source's frames (mutex_ held).
  void ReportRefused(size_t frames_sent);
  void Summarize();

  const PlayerOptions options_;
  DatasetPlayer player_;
  PlayerStats stats_;
  const Clock::time_point begin_;
  Clock::time_point start_;  // of the replay's schedule (the first frame); moved on when stopped
  // A stop of the player itself (SIGSTOP, Ctrl-Z) is not the pipeline's: the times measured
  // across it (latency, the wait for a result) are left out, and the replay resumes at the
  // camera's rate rather than sending the frames it fell behind in one burst.
  unsigned continued_at_last_pose_, continued_at_last_frame_;
  Timestamp first_stamp_;

  std::mutex mutex_;
  std::condition_variable cv_;
  int64_t acked_ = -1;  // highest seq whose pose was received
  // End-to-end latency: when each frame was published, and from it to its pose's arrival here.
  std::map<uint64_t, Clock::time_point> sent_;
  // The stamp of each frame published and not yet acknowledged: a pose is for one of this
  // player's frames only when its seq and stamp are one of them (another frame source on the
  // partition numbers its frames from 0 too).
  std::map<uint64_t, Timestamp> sent_stamps_;
  size_t own_poses_ = 0, foreign_poses_ = 0;
  bool refused_ = false;  // the run's slam takes another frame source's frames, not ours
  // The pose writers of the slam components that announced themselves on the partition: only
  // their poses for other frames tell that the consumers took another frame source; any other
  // participant publishing poses into the partition proves nothing about them.
  std::set<WriterGuid> slam_pose_writers_;
  LatencyReservoir latency_ms_;
  std::vector<ResultLatency> latencies_;
  const double late_after_ms_;
  size_t late_ = 0;
  std::optional<Clock::time_point> first_sent_, last_pose_;
  std::chrono::duration<double> longest_gap_{0};
  bool slam_done_ = false;
  bool recorder_done_ = false;
  WriterGoneWatch recorder_watch_{std::chrono::seconds(5)};
  bool mapper_done_ = false;
  // Recorder / mapper that announced DONE with a reason (stopped before the end) or FAILED.
  std::map<ComponentKind, std::string> consumers_cut_short_;
  std::optional<WriterGuid> mapper_status_writer_;  // from the mapper's announcements
  WriterGoneWatch mapper_watch_{std::chrono::seconds(5)};
  // slam ended before the end of the stream: it said why (stopped by a signal, failed), or it
  // was done before this player announced the end of its stream.
  std::string slam_cut_short_;
  bool end_of_stream_sent_ = false;
  std::set<ComponentKind> ready_;   // components that announced READY
  std::set<ComponentKind> failed_;  // components that announced FAILED: not waited for
  RepeatedWarning rival_warning_;   // a rival announces itself again as peers join
  WriterGoneWatch slam_watch_{std::chrono::seconds(5)};
  bool slam_gone_reported_ = false;
  // The endpoints last: their listeners use the state above.
  dds::Writer<msg::RgbdFramePubSubType> frames_;
  dds::Writer<msg::GroundTruthPosePubSubType> gt_writer_;
  dds::Writer<msg::StreamStatusPubSubType> status_;
  dds::Reader<msg::CameraPosePubSubType> poses_;
  StatusReader status_reader_;
  StartedAnnouncer started_;
};

double PlayerShell::LateAfterMs() const {
  if (options_.rate <= 0 || player_.num_frames() <= 1) return 0;
  const double span_s = SecondsBetween(player_.Stamp(0), player_.Stamp(player_.num_frames() - 1));
  return kLateFramePeriods * 1000.0 * span_s / static_cast<double>(player_.num_frames() - 1) /
         options_.rate;
}

void PlayerShell::OnPose(const msg::CameraPose& pose, const WriterGuid& writer) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const uint64_t seq = pose.header().seq();
    const auto stamp_it = sent_stamps_.find(seq);
    Timestamp stamp;
    try {
      stamp = TimeFromMsg(pose.header().stamp(), "CameraPose.header.stamp");
    } catch (const InputError&) {
      return;  // a malformed sample (the reader's own checks report those)
    }
    if (stamp_it == sent_stamps_.end() || stamp_it->second != stamp) {
      // Not ours: a pose for another frame source's frame. Many of them from a slam component
      // while none of ours came back: the consumers took the other source (it started first).
      if (slam_pose_writers_.count(writer) == 0) return;
      ++foreign_poses_;
      if (own_poses_ == 0 && foreign_poses_ >= kRefusedAfterForeignPoses) refused_ = true;
      cv_.notify_all();
      return;
    }
    ++own_poses_;
    sent_stamps_.erase(sent_stamps_.begin(), std::next(stamp_it));
    acked_ = std::max<int64_t>(acked_, static_cast<int64_t>(seq));
    const auto it = sent_.find(seq);
    if (it != sent_.end()) {
      const auto now = Clock::now();
      const unsigned continued = TimesContinued();
      if (continued == continued_at_last_pose_) {
        const double ms = std::chrono::duration<double, std::milli>(now - it->second).count();
        latency_ms_.Add(ms);
        if (options_.rate > 0 && latencies_.size() < kMaxLatencyRows)
          latencies_.push_back({stamp, ms});
        if (late_after_ms_ > 0 && ms > late_after_ms_) ++late_;
        // The wait for a result while a frame was out: from the last result or from when the
        // oldest frame still out was sent, whichever is later (a player that sent nothing for
        // a while, throttled, is no stall of the pipeline).
        longest_gap_ = std::max(longest_gap_, WaitWithFrameOut(now, last_pose_, sent_));
      }
      continued_at_last_pose_ = continued;
      last_pose_ = now;
      sent_.erase(sent_.begin(), std::next(it));
    }
  }
  cv_.notify_all();
}

void PlayerShell::OnStatus(const ComponentStatus& s, const WriterGuid& from) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    // Another frame source on the partition: the consumers take the frames of the one that
    // announced itself first and ignore the other's (components/protocol.h).
    if (s.event == StreamEvent::kStarted && IsFrameSource(s.source) &&
        !std::equal(from.begin(), from.begin() + 12, frames_.guid().begin()) &&
        rival_warning_.Say()) {
      LOG_WARNING << "player: another frame source (" << ToString(s.source)
                  << ") plays on this partition; the run's consumers take the frames of "
                  << "the one that started first and ignore the other's (give each run its "
                  << "own --partition)";
    }
    if (s.source == ComponentKind::kSlam &&
        (s.event == StreamEvent::kComponentDone || s.event == StreamEvent::kFailed)) {
      slam_done_ = true;
      if (s.event == StreamEvent::kFailed)
        slam_cut_short_ = "failed: " + s.reason;
      else if (!s.reason.empty())
        slam_cut_short_ = s.reason;
      else if (!end_of_stream_sent_)
        slam_cut_short_ = "was done before the end of the stream";
    }
    if (s.event == StreamEvent::kReady) ready_.insert(s.source);
    if (s.event == StreamEvent::kFailed) failed_.insert(s.source);
    if ((s.source == ComponentKind::kRecorder || s.source == ComponentKind::kMapper) &&
        (s.event == StreamEvent::kComponentDone || s.event == StreamEvent::kFailed)) {
      (s.source == ComponentKind::kRecorder ? recorder_done_ : mapper_done_) = true;
      // Its output ends early: it failed, or a stop signal ended it before slam's end.
      if (s.event == StreamEvent::kFailed || !s.reason.empty())
        consumers_cut_short_[s.source] =
            s.event == StreamEvent::kFailed ? "failed: " + s.reason : s.reason;
    }
    if (s.source == ComponentKind::kMapper && s.event == StreamEvent::kReady)
      mapper_status_writer_ = from;
    if (s.event == StreamEvent::kStarted && s.source == ComponentKind::kSlam) {
      if (const auto it = s.writers.find(DataTopic::kCameraPose); it != s.writers.end())
        slam_pose_writers_.insert(it->second);
    }
  }
  cv_.notify_all();
}

void PlayerShell::WaitForPeers(const StopFlagPtr& stop) {
  const auto readers_deadline =
      Clock::now() +
      std::chrono::milliseconds(static_cast<int64_t>(options_.wait_for_readers_s * 1000));
  while (frames_.matched() < ExpectedReaders() && Clock::now() < readers_deadline &&
         !stop->WaitFor(std::chrono::milliseconds(10))) {
  }
  if (frames_.matched() < ExpectedReaders() && !stop->requested()) {
    LOG_WARNING << "player: only " << frames_.matched() << " of " << ExpectedReaders()
                << " frame readers after " << options_.wait_for_readers_s << " s; playing anyway";
  }
  const auto deadline =
      Clock::now() +
      std::chrono::milliseconds(static_cast<int64_t>(options_.wait_for_components_s * 1000));
  std::unique_lock<std::mutex> lock(mutex_);
  auto missing = [&] {
    std::string names;
    for (const ComponentKind kind : options_.wait_for_components) {
      if (!ready_.count(kind) && !failed_.count(kind))
        names += std::string(names.empty() ? "" : ", ") + ToString(kind);
    }
    return names;
  };
  while (!missing().empty() && !stop->requested() && Clock::now() < deadline) {
    cv_.wait_for(lock, std::chrono::milliseconds(20));
  }
  if (!missing().empty() && !stop->requested()) {
    LOG_WARNING << "player: no READY announcement from " << missing() << " after "
                << options_.wait_for_components_s << " s; playing anyway";
  }
}

int PlayerShell::ExpectedReaders() {
  // A frame reader (detector, slam) that announced FAILED will not come.
  std::lock_guard<std::mutex> lock(mutex_);
  return options_.expected_readers - static_cast<int>(failed_.count(ComponentKind::kDetector) +
                                                      failed_.count(ComponentKind::kSlam));
}

void PlayerShell::AwaitReadersAfterResume(Clock::duration paused, const StopFlagPtr& stop) {
  if (paused < kPauseOverLease) return;  // the peers' leases held: nobody was dropped
  const auto deadline = Clock::now() + WriterGoneWatch::kResumeGrace;
  bool dropped = false;
  while (Clock::now() < deadline && !stop->WaitFor(std::chrono::milliseconds(10))) {
    const bool all = frames_.matched() >= ExpectedReaders();
    dropped = dropped || !all;
    if (dropped && all) return;  // dropped for the expired lease, and found again
  }
}

bool PlayerShell::WaitUntilDue(size_t n, const RgbdFrameData& frame, const StopFlagPtr& stop) {
  auto due = [&] {
    return start_ + std::chrono::nanoseconds(static_cast<int64_t>(
                        (frame.stamp.nanoseconds() - first_stamp_.nanoseconds()) / options_.rate));
  };
  if (const unsigned continued = TimesContinued(); continued != continued_at_last_frame_) {
    continued_at_last_frame_ = continued;
    AwaitReadersAfterResume(Clock::now() - due(), stop);
    if (const auto behind = Clock::now() - due(); behind > Clock::duration::zero()) {
      start_ += behind;
      LOG_INFO << "player: stopped and continued; the replay goes on at the camera's rate "
               << "from frame " << n;
    }
  }
  return !stop->WaitFor(due() - Clock::now());
}

void PlayerShell::WaitForWindow(size_t n, const StopFlagPtr& stop) {
  const int64_t need = static_cast<int64_t>(n) - options_.window;
  const auto deadline =
      Clock::now() + std::chrono::milliseconds(static_cast<int64_t>(options_.ack_timeout_s * 1000));
  std::unique_lock<std::mutex> lock(mutex_);
  // No acknowledgement will come: stopped, refused, slam gone or done (stopped, failed).
  const auto waiting = [&] {
    return acked_ < need && !stop->requested() && !SlamGone() && !refused_ && !slam_done_;
  };
  while (waiting() && Clock::now() < deadline) cv_.wait_for(lock, std::chrono::milliseconds(20));
  if (waiting()) {
    ++stats_.ack_timeouts;
    LOG_WARNING << "player: no acknowledgement of frame " << need << " after "
                << options_.ack_timeout_s << " s; sending frame " << n;
  }
}

void PlayerShell::PlayFrames(const StopFlagPtr& stop) {
  const int64_t replay_shift_ns = player_.num_frames() == 0
                                      ? 0
                                      : player_.Stamp(player_.num_frames() - 1).nanoseconds() -
                                            player_.Stamp(0).nanoseconds() + 1000000000LL;
  const auto loop_end =
      begin_ + std::chrono::milliseconds(static_cast<int64_t>(options_.loop_minutes * 60000));
  const size_t frames_per_loop = player_.num_frames();
  for (size_t n = 0; frames_per_loop > 0 && !stop->requested(); ++n) {
    const size_t loop = n / frames_per_loop;
    if (n % frames_per_loop == 0 && loop > 0 &&
        (options_.loop_minutes <= 0 || Clock::now() >= loop_end)) {
      break;
    }
    started_.Poll(status_);  // until the end of stream
    RgbdFrameData frame = player_.Frame(n % frames_per_loop);
    frame.seq = n;
    frame.stamp = Timestamp::FromNanoseconds(frame.stamp.nanoseconds() + loop * replay_shift_ns);
    if (n == 0) {
      // The camera starts with the first frame: the schedule from now, not from the start-up
      // (the wait for the components), which sent the first frames in a burst to catch up.
      first_stamp_ = frame.stamp;
      start_ = Clock::now();
    }
    if (options_.rate > 0 && !WaitUntilDue(n, frame, stop)) break;
    if (options_.window > 0 && n >= static_cast<size_t>(options_.window)) WaitForWindow(n, stop);
    if (stop->requested()) break;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (refused_) {
        ReportRefused(n);
        break;
      }
      // slam ended before the end of the stream (stopped by a signal, failed; OnStatus gives
      // every DONE before the end of stream a reason): the rest of the frames would go to
      // nobody. EndStream says why.
      if (slam_done_) break;
      // The watch sees slam's pose writer while it is there, so that its leaving (killed, no
      // DONE) is noticed also when no frame ever waited for an acknowledgement.
      SlamGone();
      const auto now = Clock::now();
      sent_[n] = now;
      sent_stamps_[n] = frame.stamp;
      if (!first_sent_) first_sent_ = now;
    }
    if (!frames_.Write(RgbdFrameToMsg(frame))) {
      LOG_WARNING << "player: frame " << n << " was not accepted by the writer";
      continue;
    }
    ++stats_.frames_published;
  }
}

void PlayerShell::ReportRefused(size_t frames_sent) {
  stats_.refused = true;
  LOG_ERROR << "player: the consumers on this partition take the frames of another frame "
            << "source (" << foreign_poses_ << " poses for its frames, none for this player's "
            << frames_sent << "): this player's frames are refused; stopping (give each run its "
            << "own --partition)";
}

void PlayerShell::EndStream(const StopFlagPtr& stop) {
  {
    // Frames published after the last pose that came back: a gap too.
    std::lock_guard<std::mutex> lock(mutex_);
    if (TimesContinued() == continued_at_last_pose_)
      longest_gap_ = std::max(longest_gap_, WaitWithFrameOut(Clock::now(), last_pose_, sent_));
    stats_.longest_gap_s = longest_gap_.count();
  }
  const uint64_t last_seq = stats_.frames_published == 0 ? 0 : stats_.frames_published - 1;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    end_of_stream_sent_ = true;
  }
  status_.Write(ToMsg(
      ComponentStatus::EndOfStream(ComponentKind::kPlayer, stats_.frames_published, last_seq)));
  LOG_INFO << "player: published " << stats_.frames_published << " frames, end of stream";
  // Stay alive (frames and ground truth remain available to late readers) until slam is done, or
  // gone without saying so.
  // A player refused after its last frame (a short stretch, or a slam slower than the camera)
  // learns it here: poses for another source's frames and, when slam is done, none for its own.
  bool slam_said_done = false;
  std::string slam_cut_short;
  {
    std::unique_lock<std::mutex> lock(mutex_);
    while (!slam_done_ && !stop->requested() && !SlamGone() && (stats_.refused || !refused_)) {
      cv_.wait_for(lock, std::chrono::milliseconds(50));
    }
    slam_said_done = slam_done_;
    slam_cut_short = slam_cut_short_;
    if (!stats_.refused && !stop->requested() && stats_.frames_published > 0 && own_poses_ == 0 &&
        (refused_ || (slam_said_done && foreign_poses_ > 0))) {
      ReportRefused(stats_.frames_published);
      return;
    }
  }
  if (slam_said_done && !slam_cut_short.empty() && !stop->requested()) {
    LOG_WARNING << "player: slam " << slam_cut_short
                << "; ending (the frames it did not process have no pose)";
    stats_.slam_left_early = true;
  }
  if (slam_gone_reported_ && !slam_said_done) {
    LOG_WARNING << "player: slam left without announcing that it is done; ending (the frames it "
                   "did not process have no pose)";
    stats_.slam_left_early = true;
  }
  if (!options_.watch_consumers) return;
  if (slam_said_done && !ConsumerFinished(ComponentKind::kRecorder, stop)) {
    LOG_WARNING << "player: the recorder left without announcing that it is done; the run's "
                   "trajectory and frames.csv were not written";
    stats_.recorder_left_early = true;
  }
  if (slam_said_done && !ConsumerFinished(ComponentKind::kMapper, stop)) {
    LOG_WARNING << "player: the mapper left without announcing that it is done; the run's map "
                   "lacks what it had not written";
    stats_.mapper_left_early = true;
  }
  std::map<ComponentKind, std::string> cut_short;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    cut_short = consumers_cut_short_;
  }
  for (const auto& [kind, reason] : cut_short) {
    if (stop->requested()) break;
    LOG_WARNING << "player: the " << ToString(kind) << " " << reason << "; "
                << (kind == ComponentKind::kMapper ? "the run's map" : "the run's trajectory")
                << " ends there";
    (kind == ComponentKind::kMapper ? stats_.mapper_left_early : stats_.recorder_left_early) = true;
  }
}

bool PlayerShell::ConsumerFinished(ComponentKind kind, const StopFlagPtr& stop) {
  const auto& wanted = options_.wait_for_components;
  const bool recorder = kind == ComponentKind::kRecorder;
  std::unique_lock<std::mutex> lock(mutex_);
  // It was there: it said READY (the mapper's status writer is known from its READY), also when
  // it left before slam's end.
  const bool announced = recorder ? ready_.count(kind) > 0 : mapper_status_writer_.has_value();
  if (std::find(wanted.begin(), wanted.end(), kind) == wanted.end() || !announced) return true;
  const bool& done = recorder ? recorder_done_ : mapper_done_;
  WriterGoneWatch& watch = recorder ? recorder_watch_ : mapper_watch_;
  // Its presence: the recorder's ground-truth reader matched on this player's writer, the
  // mapper's status writer on this player's status reader.
  const auto present = [&] {
    return recorder ? gt_writer_.matched() > 0 : status_reader_.IsMatched(*mapper_status_writer_);
  };
  bool gone = false;
  watch.Seen();
  while (!done && !stop->requested() && !(gone = watch.Update(present())))
    cv_.wait_for(lock, std::chrono::milliseconds(50));
  return !gone || done;
}

void PlayerShell::Summarize() {
  stats_.seconds = std::chrono::duration<double>(Clock::now() - begin_).count();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stats_.poses_timed = latency_ms_.count();
    stats_.latency_median_ms = latency_ms_.Quantile(0.5);
    stats_.latency_p95_ms = latency_ms_.Quantile(0.95);
    stats_.latency_p99_ms = latency_ms_.Quantile(0.99);
    stats_.late = late_;
    stats_.latencies = latencies_;
    if (first_sent_ && last_pose_ && latency_ms_.count() > 1) {
      stats_.poses_per_second = (latency_ms_.count() - 1) /
                                std::chrono::duration<double>(*last_pose_ - *first_sent_).count();
    }
  }
  if (stats_.poses_timed > 0) {
    LOG_INFO << "player: frame-to-pose latency median " << stats_.latency_median_ms << " ms, 95th "
             << stats_.latency_p95_ms << " ms over " << stats_.poses_timed << " frames; "
             << stats_.poses_per_second << " poses/s";
  }
}

PlayerStats PlayerShell::Run(const StopFlagPtr& stop) {
  WaitForPeers(stop);
  if (options_.publish_ground_truth) {
    uint64_t seq = 0;
    for (const StampedPose& p : player_.GroundTruth()) {
      gt_writer_.Write(GroundTruthToMsg(p, seq++));
      ++stats_.ground_truth_published;
    }
  }
  PlayFrames(stop);
  EndStream(stop);
  Summarize();
  return stats_;
}

}  // namespace

PlayerStats RunPlayer(std::shared_ptr<dds::Participant> participant, const PlayerOptions& options,
                      const StopFlagPtr& stop) {
  options.Check();
  PlayerShell shell(std::move(participant), options);
  return shell.Run(stop);
}

}  // namespace dygslam
