#include "components/recorder.h"

#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <mutex>
#include <optional>
#include <utility>
#include <vector>

#include "components/convert.h"
#include "components/dds/participant.h"
#include "components/dds/pubsub.h"
#include "components/protocol.h"
#include "components/status_reader.h"
#include "core/base/error.h"
#include "core/base/log.h"
#include "dygslam_msg/CameraPosePubSubTypes.h"
#include "dygslam_msg/GroundTruthPubSubTypes.h"
#include "dygslam_msg/StreamStatusPubSubTypes.h"
#include "dygslam_msg/TrajectoryPubSubTypes.h"

namespace dygslam {
namespace {

using Clock = std::chrono::steady_clock;

// The recorder's shell: its readers feed RecorderCore through the writer gates (only the writers
// this run's components announced), its loop waits for slam's end, then the files are written.
class RecorderShell {
 public:
  RecorderShell(std::shared_ptr<dds::Participant> participant, const RecorderOptions& options)
      : options_(options),
        core_(options),
        start_(Clock::now()),
        status_(participant, dds::topics::kStreamStatus, dds::TopicKind::kStreamStatus),
        poses_(participant, dds::topics::kCameraPose, dds::TopicKind::kCameraPose,
               [this](msg::CameraPose&& p, const WriterGuid& writer) {
                 std::lock_guard<std::mutex> lock(mutex_);
                 Admit(&pose_gate_, std::move(p), writer, [this](const auto& m) { AddPose(m); });
               }),
        trajectories_(participant, dds::topics::kTrajectory, dds::TopicKind::kTrajectory,
                      [this](msg::Trajectory&& t, const WriterGuid& writer) {
                        std::lock_guard<std::mutex> lock(mutex_);
                        Admit(&trajectory_gate_, std::move(t), writer,
                              [this](const auto& m) { SetTrajectory(m); });
                      }),
        ground_truth_(participant, dds::topics::kGroundTruth, dds::TopicKind::kGroundTruth,
                      [this](msg::GroundTruthPose&& p, const WriterGuid& writer) {
                        std::lock_guard<std::mutex> lock(mutex_);
                        Admit(&truth_gate_, std::move(p), writer,
                              [this](const auto& m) { AddGroundTruth(m); });
                      }),
        status_reader_(participant, ComponentKind::kRecorder,
                       [this](const ComponentStatus& s, const msg::StreamStatus& /*m*/,
                              const WriterGuid& from) { OnStatus(s, from); }),
        started_(status_, ComponentStatus::Started(ComponentKind::kRecorder, {})) {}

  RecorderStats Run(const StopFlagPtr& stop);

 private:
  static constexpr auto kMaxHold = std::chrono::milliseconds(5000);

  void AddPose(const msg::CameraPose& p);
  void SetTrajectory(const msg::Trajectory& t);
  void AddGroundTruth(const msg::GroundTruthPose& p);
  void OnStatus(const ComponentStatus& s, const WriterGuid& from);
  // Passes a sample through its gate and uses what may be used now (under mutex_).
  template <class Gate, class Sample, class Use>
  void Admit(Gate* gate, Sample&& sample, const WriterGuid& writer, const Use& use) {
    std::vector<std::decay_t<Sample>> ready;
    gate->Offer(std::move(sample), writer, Clock::now(), &ready);
    for (const auto& message : ready) use(message);
  }
  void ReleaseHeld();
  // Waits (under `lock`) for slam's end (its final trajectories, or DONE), its departure or a stop.
  void WaitForSlam(std::unique_lock<std::mutex>& lock, const StopFlagPtr& stop);
  // slam finished, but the frame source never ended its stream: the trajectory lacks its end.
  void CheckStreamEnded(std::unique_lock<std::mutex>& lock, const StopFlagPtr& stop);

  const RecorderOptions options_;
  RecorderCore core_;
  RecorderStats stats_;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool slam_done_ = false;
  std::string slam_cut_short_;  // slam said it ended before the end of the stream, and why
  uint64_t total_frames_ = 0;   // announced by the player (STARTED)
  const Clock::time_point start_;
  std::optional<Clock::time_point> first_pose_;
  // Only the writers announced by this run's components (components/protocol.h): poses and
  // trajectories of slam, ground truth of the player; early samples wait briefly for the
  // announcement.
  RunWriters writers_;
  WriterGate<msg::CameraPose> pose_gate_{&writers_, DataTopic::kCameraPose, 4096, kMaxHold};
  WriterGate<msg::Trajectory> trajectory_gate_{&writers_, DataTopic::kTrajectory, 16, kMaxHold};
  WriterGate<msg::GroundTruthPose> truth_gate_{&writers_, DataTopic::kGroundTruth, 65536, kMaxHold};
  // The endpoints last: their listeners use the state above.
  dds::Writer<msg::StreamStatusPubSubType> status_;
  dds::Reader<msg::CameraPosePubSubType> poses_;
  dds::Reader<msg::TrajectoryPubSubType> trajectories_;
  dds::Reader<msg::GroundTruthPosePubSubType> ground_truth_;
  StatusReader status_reader_;
  StartedAnnouncer started_;
};

void RecorderShell::AddPose(const msg::CameraPose& p) {
  try {
    core_.AddPose(p);
    ++stats_.poses;
  } catch (const InputError& e) {
    ++stats_.bad_samples;
    LOG_WARNING << "recorder: dropped pose: " << e.what();
    return;
  }
  const auto now = Clock::now();
  if (!first_pose_) first_pose_ = now;
  const size_t n = core_.num_frames();
  if (options_.progress && (n % 10 == 0 || n == total_frames_)) {
    const double elapsed = std::chrono::duration<double>(now - start_).count();
    std::fprintf(stderr, "\r[run] frame %zu/%llu  %.1f fps  state=%s  lost=%zu   ", n,
                 static_cast<unsigned long long>(total_frames_), n / std::max(elapsed, 1e-9),
                 p.tracking_state() <= static_cast<uint8_t>(TrackingState::kFallback)
                     ? ToString(static_cast<TrackingState>(p.tracking_state()))
                     : "?",
                 core_.num_lost());
    std::fflush(stderr);
  }
}

void RecorderShell::SetTrajectory(const msg::Trajectory& t) {
  try {
    core_.SetTrajectory(t);
  } catch (const InputError& e) {
    ++stats_.bad_samples;
    LOG_WARNING << "recorder: dropped trajectory: " << e.what();
  }
  cv_.notify_all();
}

void RecorderShell::AddGroundTruth(const msg::GroundTruthPose& p) {
  try {
    core_.AddGroundTruth(p);
  } catch (const InputError& e) {
    ++stats_.bad_samples;
  }
}

void RecorderShell::ReleaseHeld() {
  const auto now = Clock::now();
  std::vector<msg::CameraPose> ready_poses;
  std::vector<msg::Trajectory> ready_trajectories;
  std::vector<msg::GroundTruthPose> ready_truth;
  pose_gate_.Release(now, &ready_poses);
  trajectory_gate_.Release(now, &ready_trajectories);
  truth_gate_.Release(now, &ready_truth);
  for (const auto& p : ready_poses) AddPose(p);
  for (const auto& t : ready_trajectories) SetTrajectory(t);
  for (const auto& g : ready_truth) AddGroundTruth(g);
}

void RecorderShell::OnStatus(const ComponentStatus& s, const WriterGuid& from) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!writers_.Announce(s, from)) return;  // a second frame source: not this run's
  if (s.event == StreamEvent::kStarted) ReleaseHeld();
  if (s.event == StreamEvent::kStarted && s.source == ComponentKind::kPlayer) {
    total_frames_ = s.num_frames;
  }
  if (s.source == ComponentKind::kSlam &&
      (s.event == StreamEvent::kComponentDone || s.event == StreamEvent::kFailed)) {
    slam_done_ = true;
    if (s.event == StreamEvent::kComponentDone) slam_cut_short_ = s.reason;
  }
  cv_.notify_all();
}

void RecorderShell::WaitForSlam(std::unique_lock<std::mutex>& lock, const StopFlagPtr& stop) {
  std::optional<Clock::time_point> done_at, flush_deadline;
  WriterGoneWatch slam_watch(std::chrono::seconds(5));
  ReadyAnnouncer announcer(ComponentKind::kRecorder);
  PauseWatch pause;
  while (true) {
    pause.Tick();
    if (!announcer.done()) {
      // Never write while holding `mutex_`: intra-process delivery runs our own listeners
      // (which take it) on this thread.
      lock.unlock();
      started_.Poll(status_);
      announcer.Poll(status_, poses_.matched() > 0 && trajectories_.matched() > 0);
      lock.lock();
    }
    if (core_.has_final_trajectory() && core_.has_final_keyframes()) break;
    if (stop->requested()) {
      // Stopping: slam sends its final trajectories as it stops; wait for them while it is
      // there (bounded).
      const auto now = Clock::now();
      if (!flush_deadline) {
        flush_deadline =
            now + std::chrono::milliseconds(static_cast<int64_t>(options_.flush_timeout_s * 1000));
      }
      if (now >= *flush_deadline || trajectories_.matched() == 0) break;
    }
    // A slam that was there and left without DONE (killed, or its DONE lost): both its writers
    // unmatched for 5 s; write what came.
    const bool slam_gone = slam_watch.Update(poses_.matched() > 0 || trajectories_.matched() > 0);
    if (slam_gone && !slam_done_) {
      stats_.input_cut_short = true;
      if (pause.WasPaused()) {
        LOG_WARNING << "recorder: this process was stopped (SIGSTOP) and continued, for about "
                    << pause.LongestSeconds() << " s, and slam left meanwhile; the poses it "
                    << "sent then are lost: writing the poses that came";
      } else {
        LOG_WARNING << "recorder: slam left without announcing that it is done; writing the "
                       "poses that came";
      }
      break;
    }
    if (slam_done_ && !done_at) done_at = Clock::now();
    // slam writes its final trajectories before DONE; give them 3 s, or up to 15 s while the
    // slam is still there (it stays until they are acknowledged).
    const auto since_done = done_at ? Clock::now() - *done_at : std::chrono::seconds(0);
    if (done_at && since_done > std::chrono::seconds(3) &&
        (trajectories_.matched() == 0 || since_done > std::chrono::seconds(15))) {
      LOG_WARNING << "recorder: slam is done but its final trajectory did not arrive; writing "
                     "the online poses";
      break;
    }
    cv_.wait_for(lock, std::chrono::milliseconds(50));
    ReleaseHeld();  // expire held samples
  }
}

void RecorderShell::CheckStreamEnded(std::unique_lock<std::mutex>& lock, const StopFlagPtr& stop) {
  // slam finished (its final trajectories came, or its DONE), but the frame source never ended
  // its stream (killed, or failed): slam finished with the frames that came, and the
  // trajectory lacks the rest. The end of the stream is sent before slam's last samples, from
  // another writer: allow it a moment to arrive.
  if (!stats_.input_cut_short && !stop->requested()) {
    // slam's DONE (which says whether slam itself was stopped early) follows its trajectories.
    cv_.wait_for(lock, std::chrono::seconds(2), [&] {
      return !slam_cut_short_.empty() || (slam_done_ && !writers_.StreamUnfinished());
    });
    if (!slam_cut_short_.empty()) {
      stats_.input_cut_short = true;
      LOG_WARNING << "recorder: slam " << slam_cut_short_
                  << ": the trajectory lacks the frames slam did not process";
    } else if (writers_.StreamUnfinished()) {
      stats_.input_cut_short = true;
      LOG_WARNING << "recorder: slam is done but the frame source never announced the end of "
                     "its stream (slam stopped before the end, or the frame source stopped or "
                     "failed): the trajectory lacks the frames slam did not process";
    }
  }
}

RecorderStats RecorderShell::Run(const StopFlagPtr& stop) {
  bool slam_done = false;
  {
    std::unique_lock<std::mutex> lock(mutex_);
    WaitForSlam(lock, stop);
    CheckStreamEnded(lock, stop);
    // Samples whose writer never announced itself: not from this run either.
    pose_gate_.Close();
    trajectory_gate_.Close();
    truth_gate_.Close();
    stats_.foreign_samples =
        pose_gate_.ignored() + trajectory_gate_.ignored() + truth_gate_.ignored();
    stats_.poses_missed = static_cast<size_t>(poses_.losses().missed);
    if (stats_.poses_missed > 0) {
      LOG_WARNING << "recorder: " << stats_.poses_missed << " per-frame poses of slam never "
                  << "arrived (they left slam's pose history while this process was paused or "
                  << "starved): frames.csv and trajectory_online.txt lack them";
    }
    stats_.final_trajectory = core_.has_final_trajectory();
    slam_done = slam_done_;
    stats_.trajectory_path = core_.Write();
    if (options_.progress && core_.num_frames() > 0) std::fprintf(stderr, "\n");
  }
  // Stopped before slam's end: the peers (a hand-started player) are told the outputs end there.
  status_.Write(ToMsg(
      ComponentStatus::Done(ComponentKind::kRecorder, 0, StoppedBeforeTheEnd(*stop, slam_done))));
  status_.WaitForAcknowledgments(std::chrono::milliseconds(2000));
  if (stats_.foreign_samples > 0) {
    LOG_WARNING << "recorder: "
                << IgnoredSamplesNote(std::to_string(stats_.foreign_samples) + " samples");
  }
  if (!stats_.trajectory_path.empty() && core_.num_frames() > 0) {
    LOG_INFO << "recorder: wrote " << stats_.trajectory_path
             << (stats_.final_trajectory ? " (final trajectory)" : " (online poses)");
  }
  return stats_;
}

}  // namespace

RecorderStats RunRecorder(std::shared_ptr<dds::Participant> participant,
                          const RecorderOptions& options, const StopFlagPtr& stop) {
  RecorderShell shell(std::move(participant), options);
  return shell.Run(stop);
}

}  // namespace dygslam
