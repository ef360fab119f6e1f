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

RecorderStats RunRecorder(std::shared_ptr<dds::Participant> participant,
                          const RecorderOptions& options, const StopFlagPtr& stop) {
  RecorderCore core(options);
  RecorderStats stats;
  std::mutex mutex;
  std::condition_variable cv;
  bool slam_done = false;
  uint64_t total_frames = 0;  // announced by the player (STARTED)
  const auto start = std::chrono::steady_clock::now();
  std::optional<std::chrono::steady_clock::time_point> first_pose;

  dds::Writer<msg::StreamStatusPubSubType> status(participant, dds::topics::kStreamStatus,
                                                  dds::TopicKind::kStreamStatus);
  // Only the writers announced by this run's components (components/protocol.h): poses and
  // trajectories of slam, ground truth of the player; early samples wait briefly for the
  // announcement.
  RunWriters writers;
  constexpr auto kMaxHold = std::chrono::milliseconds(5000);
  WriterGate<msg::CameraPose> pose_gate(&writers, DataTopic::kCameraPose, 4096, kMaxHold);
  WriterGate<msg::Trajectory> trajectory_gate(&writers, DataTopic::kTrajectory, 16, kMaxHold);
  WriterGate<msg::GroundTruthPose> truth_gate(&writers, DataTopic::kGroundTruth, 65536, kMaxHold);
  const auto add_pose = [&](const msg::CameraPose& p) {
    try {
      core.AddPose(p);
      ++stats.poses;
    } catch (const InputError& e) {
      ++stats.bad_samples;
      LOG_WARNING << "recorder: dropped pose: " << e.what();
      return;
    }
    const auto now = std::chrono::steady_clock::now();
    if (!first_pose) first_pose = now;
    const size_t n = core.num_frames();
    if (options.progress && (n % 10 == 0 || n == total_frames)) {
      const double elapsed = std::chrono::duration<double>(now - start).count();
      std::fprintf(stderr, "\r[run] frame %zu/%llu  %.1f fps  state=%s  lost=%zu   ", n,
                   static_cast<unsigned long long>(total_frames), n / std::max(elapsed, 1e-9),
                   p.tracking_state() <= static_cast<uint8_t>(TrackingState::kFallback)
                       ? ToString(static_cast<TrackingState>(p.tracking_state()))
                       : "?",
                   core.num_lost());
      std::fflush(stderr);
    }
  };
  const auto set_trajectory = [&](const msg::Trajectory& t) {
    try {
      core.SetTrajectory(t);
    } catch (const InputError& e) {
      ++stats.bad_samples;
      LOG_WARNING << "recorder: dropped trajectory: " << e.what();
    }
    cv.notify_all();
  };
  const auto add_ground_truth = [&](const msg::GroundTruthPose& p) {
    try {
      core.AddGroundTruth(p);
    } catch (const InputError& e) {
      ++stats.bad_samples;
    }
  };
  // Passes a sample through its gate and uses what may be used now (under `mutex`).
  auto admit = [&](auto* gate, auto&& sample, const WriterGuid& writer, const auto& use) {
    std::vector<std::decay_t<decltype(sample)>> ready;
    gate->Offer(std::move(sample), writer, std::chrono::steady_clock::now(), &ready);
    for (const auto& message : ready) use(message);
  };
  auto release_held = [&] {
    const auto now = std::chrono::steady_clock::now();
    std::vector<msg::CameraPose> ready_poses;
    std::vector<msg::Trajectory> ready_trajectories;
    std::vector<msg::GroundTruthPose> ready_truth;
    pose_gate.Release(now, &ready_poses);
    trajectory_gate.Release(now, &ready_trajectories);
    truth_gate.Release(now, &ready_truth);
    for (const auto& p : ready_poses) add_pose(p);
    for (const auto& t : ready_trajectories) set_trajectory(t);
    for (const auto& g : ready_truth) add_ground_truth(g);
  };
  dds::Reader<msg::CameraPosePubSubType> poses(participant, dds::topics::kCameraPose,
                                               dds::TopicKind::kCameraPose,
                                               [&](msg::CameraPose&& p, const WriterGuid& writer) {
                                                 std::lock_guard<std::mutex> lock(mutex);
                                                 admit(&pose_gate, std::move(p), writer, add_pose);
                                               });
  dds::Reader<msg::TrajectoryPubSubType> trajectories(
      participant, dds::topics::kTrajectory, dds::TopicKind::kTrajectory,
      [&](msg::Trajectory&& t, const WriterGuid& writer) {
        std::lock_guard<std::mutex> lock(mutex);
        admit(&trajectory_gate, std::move(t), writer, set_trajectory);
      });
  dds::Reader<msg::GroundTruthPosePubSubType> ground_truth(
      participant, dds::topics::kGroundTruth, dds::TopicKind::kGroundTruth,
      [&](msg::GroundTruthPose&& p, const WriterGuid& writer) {
        std::lock_guard<std::mutex> lock(mutex);
        admit(&truth_gate, std::move(p), writer, add_ground_truth);
      });
  StatusReader status_reader(
      participant, ComponentKind::kRecorder,
      [&](const ComponentStatus& s, const msg::StreamStatus& /*m*/, const WriterGuid& from) {
        std::lock_guard<std::mutex> lock(mutex);
        if (!writers.Announce(s, from)) return;  // a second frame source: not this run's
        if (s.event == StreamEvent::kStarted) release_held();
        if (s.event == StreamEvent::kStarted && s.source == ComponentKind::kPlayer) {
          total_frames = s.num_frames;
        }
        if (s.source == ComponentKind::kSlam &&
            (s.event == StreamEvent::kComponentDone || s.event == StreamEvent::kFailed)) {
          slam_done = true;
        }
        cv.notify_all();
      });
  StartedAnnouncer started(status, ComponentStatus::Started(ComponentKind::kRecorder, {}));

  {
    std::unique_lock<std::mutex> lock(mutex);
    std::optional<std::chrono::steady_clock::time_point> done_at, flush_deadline;
    WriterGoneWatch slam_watch(std::chrono::seconds(5));
    ReadyAnnouncer announcer(ComponentKind::kRecorder);
    PauseWatch pause;
    while (true) {
      pause.Tick();
      if (!announcer.done()) {
        // Never write while holding `mutex`: intra-process delivery runs our own listeners
        // (which take it) on this thread.
        lock.unlock();
        started.Poll(status);
        announcer.Poll(status, poses.matched() > 0 && trajectories.matched() > 0);
        lock.lock();
      }
      if (core.has_final_trajectory() && core.has_final_keyframes()) break;
      if (stop->requested()) {
        // Stopping: slam sends its final trajectories as it stops; wait for them while it is
        // there (bounded).
        const auto now = std::chrono::steady_clock::now();
        if (!flush_deadline) {
          flush_deadline =
              now + std::chrono::milliseconds(static_cast<int64_t>(options.flush_timeout_s * 1000));
        }
        if (now >= *flush_deadline || trajectories.matched() == 0) break;
      }
      // A slam that was there and left without DONE (killed, or its DONE lost): both its writers
      // unmatched for 5 s; write what came.
      const bool slam_gone = slam_watch.Update(poses.matched() > 0 || trajectories.matched() > 0);
      if (slam_gone && !slam_done) {
        stats.input_cut_short = true;
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
      if (slam_done && !done_at) done_at = std::chrono::steady_clock::now();
      // slam writes its final trajectories before DONE; give them 3 s, or up to 15 s while the
      // slam is still there (it stays until they are acknowledged).
      const auto since_done =
          done_at ? std::chrono::steady_clock::now() - *done_at : std::chrono::seconds(0);
      if (done_at && since_done > std::chrono::seconds(3) &&
          (trajectories.matched() == 0 || since_done > std::chrono::seconds(15))) {
        LOG_WARNING << "recorder: slam is done but its final trajectory did not arrive; writing "
                       "the online poses";
        break;
      }
      cv.wait_for(lock, std::chrono::milliseconds(50));
      release_held();  // expire held samples
    }
    // slam finished (its final trajectories came, or its DONE), but the frame source never ended
    // its stream (killed, or failed): slam finished with the frames that came, and the
    // trajectory lacks the rest. The end of the stream is sent before slam's last samples, from
    // another writer: allow it a moment to arrive.
    if (!stats.input_cut_short && !stop->requested()) {
      cv.wait_for(lock, std::chrono::seconds(2), [&] { return !writers.StreamUnfinished(); });
      if (writers.StreamUnfinished()) {
        stats.input_cut_short = true;
        LOG_WARNING << "recorder: slam is done but the frame source never announced the end of "
                       "its stream (it was stopped or failed): the trajectory lacks the frames "
                       "it did not play";
      }
    }
    // Samples whose writer never announced itself: not from this run either.
    pose_gate.Close();
    trajectory_gate.Close();
    truth_gate.Close();
    stats.foreign_samples = pose_gate.ignored() + trajectory_gate.ignored() + truth_gate.ignored();
    stats.final_trajectory = core.has_final_trajectory();
    stats.trajectory_path = core.Write();
    if (options.progress && core.num_frames() > 0) std::fprintf(stderr, "\n");
  }
  status.Write(ToMsg(ComponentStatus::Done(ComponentKind::kRecorder)));
  status.WaitForAcknowledgments(std::chrono::milliseconds(2000));
  if (stats.foreign_samples > 0) {
    LOG_WARNING << "recorder: "
                << IgnoredSamplesNote(std::to_string(stats.foreign_samples) + " samples");
  }
  if (!stats.trajectory_path.empty()) {
    LOG_INFO << "recorder: wrote " << stats.trajectory_path
             << (stats.final_trajectory ? " (final trajectory)" : " (online poses)");
  }
  return stats;
}

}  // namespace dygslam
