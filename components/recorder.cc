#include "components/recorder.h"

#include <algorithm>
#include <filesystem>

#include "components/dds/participant.h"
#include "components/dds/pubsub.h"
#include "core/base/error.h"
#include "core/base/log.h"
#include "core/io/trajectory_io.h"
#include "dygslam_msg/CameraPosePubSubTypes.h"
#include "dygslam_msg/GroundTruthPubSubTypes.h"
#include "dygslam_msg/StreamStatusPubSubTypes.h"
#include "dygslam_msg/TrajectoryPubSubTypes.h"

namespace dygslam {

void RecorderOptions::Check() const {
  DYGSLAM_CHECK_OPTION(!output_dir.empty(), "recorder.output_dir");
}

RecorderCore::RecorderCore(const RecorderOptions& options) : options_(options) {
  options_.Check();
}

void RecorderCore::AddPose(const msg::CameraPose& pose) {
  if (!pose.has_pose()) return;
  StampedPose p;
  p.stamp = TimeFromMsg(pose.header().stamp(), "CameraPose.header.stamp");
  p.world_from_cam = PoseFromMsg(pose.world_from_cam(), "CameraPose.world_from_cam");
  online_.push_back(p);
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
  poses.erase(std::unique(poses.begin(), poses.end(),
                          [](const StampedPose& a, const StampedPose& b) {
                            return a.stamp == b.stamp;
                          }),
              poses.end());
  return poses;
}

}  // namespace

std::string RecorderCore::Write() const {
  std::filesystem::create_directories(options_.output_dir);
  const std::filesystem::path dir(options_.output_dir);
  const std::string trajectory = (dir / "trajectory.txt").string();
  WriteTumTrajectory(trajectory, final_frames_ ? *final_frames_ : SortedUnique(online_));
  WriteTumTrajectory((dir / "trajectory_online.txt").string(), SortedUnique(online_));
  if (final_keyframes_) WriteTumTrajectory((dir / "keyframes.txt").string(), *final_keyframes_);
  if (!ground_truth_.empty()) {
    WriteTumTrajectory((dir / "groundtruth.txt").string(), SortedUnique(ground_truth_));
  }
  return trajectory;
}

RecorderStats RunRecorder(std::shared_ptr<dds::Participant> participant,
                          const RecorderOptions& options, const StopSignalPtr& stop) {
  RecorderCore core(options);
  RecorderStats stats;
  std::mutex mutex;
  std::condition_variable cv;
  bool slam_done = false;

  dds::Writer<msg::StreamStatusPubSubType> status(participant, dds::topics::kStreamStatus,
                                                  dds::TopicKind::kStreamStatus);
  dds::Reader<msg::CameraPosePubSubType> poses(
      participant, dds::topics::kCameraPose, dds::TopicKind::kCameraPose,
      [&](msg::CameraPose&& p) {
        std::lock_guard<std::mutex> lock(mutex);
        try {
          core.AddPose(p);
          ++stats.poses;
        } catch (const InputError& e) {
          ++stats.bad_samples;
          LOG_WARNING << "recorder: dropped pose: " << e.what();
        }
      });
  dds::Reader<msg::TrajectoryPubSubType> trajectories(
      participant, dds::topics::kTrajectory, dds::TopicKind::kTrajectory,
      [&](msg::Trajectory&& t) {
        std::lock_guard<std::mutex> lock(mutex);
        try {
          core.SetTrajectory(t);
        } catch (const InputError& e) {
          ++stats.bad_samples;
          LOG_WARNING << "recorder: dropped trajectory: " << e.what();
        }
        cv.notify_all();
      });
  dds::Reader<msg::GroundTruthPosePubSubType> ground_truth(
      participant, dds::topics::kGroundTruth, dds::TopicKind::kGroundTruth,
      [&](msg::GroundTruthPose&& p) {
        std::lock_guard<std::mutex> lock(mutex);
        try {
          core.AddGroundTruth(p);
        } catch (const InputError& e) {
          ++stats.bad_samples;
        }
      });
  dds::Reader<msg::StreamStatusPubSubType> status_reader(
      participant, dds::topics::kStreamStatus, dds::TopicKind::kStreamStatus,
      [&](msg::StreamStatus&& s) {
        if (s.kind() == static_cast<uint8_t>(StreamEvent::kComponentDone) && s.source() == "slam") {
          std::lock_guard<std::mutex> lock(mutex);
          slam_done = true;
          cv.notify_all();
        }
      });

  {
    std::unique_lock<std::mutex> lock(mutex);
    std::optional<std::chrono::steady_clock::time_point> done_at;
    while (!stop->requested()) {
      if (core.has_final_trajectory() && core.has_final_keyframes()) break;
      if (slam_done && !done_at) done_at = std::chrono::steady_clock::now();
      if (done_at && std::chrono::steady_clock::now() - *done_at > std::chrono::seconds(3)) {
        LOG_WARNING << "recorder: slam is done but its final trajectory did not arrive; writing "
                       "the online poses";
        break;
      }
      cv.wait_for(lock, std::chrono::milliseconds(50));
    }
    stats.final_trajectory = core.has_final_trajectory();
    stats.trajectory_path = core.Write();
  }
  msg::StreamStatus done;
  done.kind(static_cast<uint8_t>(StreamEvent::kComponentDone));
  done.source("recorder");
  status.Write(done);
  status.WaitForAcknowledgments(std::chrono::milliseconds(2000));
  LOG_INFO << "recorder: wrote " << stats.trajectory_path
           << (stats.final_trajectory ? " (final trajectory)" : " (online poses)");
  return stats;
}

}  // namespace dygslam
