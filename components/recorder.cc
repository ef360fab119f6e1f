#include "components/recorder.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <utility>
#include <vector>

#include "components/dds/participant.h"
#include "components/dds/pubsub.h"
#include "components/protocol.h"
#include "core/base/echo.h"
#include "core/base/error.h"
#include "core/base/log.h"
#include "core/io/file_util.h"
#include "core/io/trajectory_io.h"
#include "dygslam_msg/CameraPosePubSubTypes.h"
#include "dygslam_msg/GroundTruthPubSubTypes.h"
#include "dygslam_msg/StreamStatusPubSubTypes.h"
#include "dygslam_msg/TrajectoryPubSubTypes.h"

namespace dygslam {

void RecorderOptions::Check() const {
  DYGSLAM_CHECK_OPTION(!output_dir.empty(), "recorder.output_dir");
  DYGSLAM_CHECK_OPTION(flush_timeout_s >= 0, "recorder.flush_timeout_s");
}

RecorderCore::RecorderCore(const RecorderOptions& options) : options_(options) {
  options_.Check();
  std::error_code ec;
  ground_truth_file_existed_ = std::filesystem::exists(std::filesystem::symlink_status(
      std::filesystem::path(options_.output_dir) / "groundtruth.txt", ec));
}

FrameRow FrameRowFromPose(const msg::CameraPose& m) {
  FrameRow row;
  row.stamp = TimeFromMsg(m.header().stamp(), "CameraPose.header.stamp");
  if (m.tracking_state() > static_cast<uint8_t>(TrackingState::kFallback)) {
    throw InputError("CameraPose.tracking_state: " + std::to_string(m.tracking_state()) +
                     " is not a tracking state (0..4)");
  }
  row.state = static_cast<TrackingState>(m.tracking_state());
  row.is_keyframe = m.is_keyframe();
  row.num_features = m.num_features();
  row.num_dynamic = m.num_dynamic();
  row.num_tracked = m.num_tracked();
  row.times.orb_extraction_ms = m.orb_extraction_ms();
  row.times.detection_ms = m.detection_ms();
  row.times.matching_ms = m.matching_ms();
  row.times.probability_ms = m.probability_ms();
  row.times.tracking_ms = m.tracking_ms();
  row.times.total_ms = m.total_ms();
  return row;
}

void RecorderCore::AddPose(const msg::CameraPose& pose) {
  const Timestamp stamp = TimeFromMsg(pose.header().stamp(), "CameraPose.header.stamp");
  std::string row = FramesCsvRow(FrameRowFromPose(pose));
  if (pose.has_pose()) {
    StampedPose p;
    p.stamp = stamp;
    p.world_from_cam = PoseFromMsg(pose.world_from_cam(), "CameraPose.world_from_cam");
    online_.push_back(p);
    if (pose.is_keyframe()) online_keyframes_.push_back(p);
  }
  if (pose.tracking_state() == static_cast<uint8_t>(TrackingState::kLost)) ++num_lost_;
  frame_rows_.emplace_back(stamp, std::move(row));
}

void RecorderCore::SetTrajectory(const msg::Trajectory& trajectory) {
  std::vector<StampedPose> poses = TrajectoryFromMsg(trajectory);
  if (trajectory.keyframes_only()) {
    final_keyframes_ = std::move(poses);
  } else {
    final_frames_ = std::move(poses);
  }
}

void RecorderCore::AddGroundTruth(const msg::GroundTruthPose& pose) {
  ground_truth_.push_back(GroundTruthFromMsg(pose));
}

namespace {

std::vector<StampedPose> SortedUnique(std::vector<StampedPose> poses) {
  std::stable_sort(poses.begin(), poses.end(),
                   [](const StampedPose& a, const StampedPose& b) { return a.stamp < b.stamp; });
  poses.erase(
      std::unique(poses.begin(), poses.end(),
                  [](const StampedPose& a, const StampedPose& b) { return a.stamp == b.stamp; }),
      poses.end());
  return poses;
}

}  // namespace

void RecorderCore::WriteGroundTruthCopy(const std::filesystem::path& path) const {
  if (!ground_truth_file_existed_) {
    WriteTumTrajectory(path.string(), SortedUnique(ground_truth_));
    return;
  }
  // Not this run's file: kept unless it already holds exactly this ground truth.
  const std::filesystem::path fresh = path.string() + ".recorder." + std::to_string(::getpid());
  WriteTumTrajectory(fresh.string(), SortedUnique(ground_truth_));
  const auto slurp = [](const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  };
  std::error_code ec;
  const bool same = std::filesystem::is_regular_file(path, ec) && slurp(path) == slurp(fresh);
  std::filesystem::remove(fresh, ec);
  if (!same) {
    LOG_WARNING << "recorder: " << EchoValue(path.string())
                << " was there before this run (not written by it): left as it was, the ground "
                   "truth of the player is not copied";
  }
}

std::string RecorderCore::Write() const {
  std::filesystem::create_directories(options_.output_dir);
  const std::filesystem::path dir(options_.output_dir);
  const std::string trajectory = (dir / "trajectory.txt").string();
  WriteTumTrajectory(trajectory, final_frames_ ? *final_frames_ : SortedUnique(online_));
  WriteTumTrajectory((dir / "trajectory_online.txt").string(), SortedUnique(online_));
  WriteTumTrajectory((dir / "keyframes.txt").string(),
                     final_keyframes_ ? *final_keyframes_ : SortedUnique(online_keyframes_));
  std::vector<std::pair<Timestamp, std::string>> rows = frame_rows_;
  std::stable_sort(rows.begin(), rows.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  std::string csv = FramesCsvHeader();
  for (const auto& row : rows) csv += row.second;
  WriteFileAtomically((dir / "frames.csv").string(), csv);
  if (!ground_truth_.empty()) WriteGroundTruthCopy(dir / "groundtruth.txt");
  return trajectory;
}

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
  dds::Reader<msg::StreamStatusPubSubType> status_reader(
      participant, dds::topics::kStreamStatus, dds::TopicKind::kStreamStatus,
      [&](msg::StreamStatus&& m) {
        ComponentStatus s;
        try {
          s = StatusFromMsg(m);
        } catch (const InputError& e) {
          LOG_WARNING << "recorder: ignored status: " << e.what();
          return;
        }
        std::lock_guard<std::mutex> lock(mutex);
        writers.Announce(s);
        if (s.event == StreamEvent::kStarted) release_held();
        if (s.event == StreamEvent::kStarted && s.source == ComponentKind::kPlayer) {
          total_frames = s.num_frames;
        }
        if (s.source == ComponentKind::kSlam &&
            (s.event == StreamEvent::kComponentDone || s.event == StreamEvent::kFailed)) {
          slam_done = true;
          cv.notify_all();
        }
      });
  status.Write(ToMsg(ComponentStatus::Started(ComponentKind::kRecorder, {})));

  {
    std::unique_lock<std::mutex> lock(mutex);
    std::optional<std::chrono::steady_clock::time_point> done_at, flush_deadline;
    ReadyAnnouncer announcer(ComponentKind::kRecorder);
    while (true) {
      if (!announcer.done()) {
        // Never write while holding `mutex`: intra-process delivery runs our own listeners
        // (which take it) on this thread.
        lock.unlock();
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
  LOG_INFO << "recorder: wrote " << stats.trajectory_path
           << (stats.final_trajectory ? " (final trajectory)" : " (online poses)");
  return stats;
}

}  // namespace dygslam
