// Recorder component: CameraPose (online poses), Trajectory (slam's final refined trajectories)
// and GroundTruthPose -> TUM files in output_dir, written atomically (temporary file + rename):
//   trajectory.txt           final trajectory of every tracked frame (slam's System::Trajectory()),
//                            or, if slam never sent it (killed / stopped), the online poses
//   keyframes.txt            final keyframe trajectory, or the online poses of keyframe frames
//   frames.csv               per-frame state, counts and stage times (same columns as
//                            `dygslam run --direct`), from CameraPose
//   trajectory_online.txt    poses as published per frame
//   groundtruth.txt          ground truth as published by the player (when received)
// Core: RecorderCore (no DDS). Shell: RunRecorder ends once both final trajectories arrived
// after slam's COMPONENT_DONE (or 3 s after DONE without them), always writing. On stop
// (SIGINT / SIGTERM) it waits up to flush_timeout_s for slam's final trajectories (slam sends
// them as it stops) while a slam writer is matched, then writes what it has.
#pragma once

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "components/component_common.h"
#include "components/convert.h"
#include "run/run_outputs.h"

namespace dygslam {

namespace dds {
class Participant;
}

struct RecorderOptions {
  std::string output_dir = ".";
  // After stop: longest wait for slam's final trajectories (seconds).
  double flush_timeout_s = 5.0;
  // Progress line on stderr ("[run] frame k/N  fps  state  lost"), every 10 frames.
  bool progress = false;
  void Check() const;
};

// One row of frames.csv (run/run_outputs.h: the columns of every `dygslam run` mode) from slam's
// CameraPose. Throws InputError for a bad stamp or tracking state.
FrameRow FrameRowFromPose(const msg::CameraPose& pose);

class RecorderCore {
 public:
  explicit RecorderCore(const RecorderOptions& options);
  void AddPose(const msg::CameraPose& pose);  // validates; poses without has_pose are skipped
  void SetTrajectory(const msg::Trajectory& trajectory);
  void AddGroundTruth(const msg::GroundTruthPose& pose);
  bool has_final_trajectory() const { return final_frames_.has_value(); }
  bool has_final_keyframes() const { return final_keyframes_.has_value(); }
  size_t num_online_poses() const { return online_.size(); }
  size_t num_frames() const { return frame_rows_.size(); }
  size_t num_lost() const { return num_lost_; }
  // Writes the files (see above). Returns the trajectory.txt path.
  std::string Write() const;

 private:
  void WriteGroundTruthCopy(const std::filesystem::path& path) const;
  RecorderOptions options_;
  std::vector<StampedPose> online_;
  std::vector<StampedPose> online_keyframes_;
  std::vector<std::pair<Timestamp, std::string>> frame_rows_;  // frames.csv rows by stamp
  size_t num_lost_ = 0;
  std::vector<StampedPose> ground_truth_;
  std::optional<std::vector<StampedPose>> final_frames_, final_keyframes_;
  // OUTPUT/groundtruth.txt was there before this recorder (a user's file, another run's): it is
  // replaced only by identical content, else left as it was with a warning.
  bool ground_truth_file_existed_ = false;
};

struct RecorderStats {
  size_t poses = 0;
  size_t bad_samples = 0;
  // Samples of writers no component of this run announced (components/protocol.h), ignored.
  size_t foreign_samples = 0;
  bool final_trajectory = false;
  std::string trajectory_path;
};

RecorderStats RunRecorder(std::shared_ptr<dds::Participant> participant,
                          const RecorderOptions& options, const StopFlagPtr& stop);

}  // namespace dygslam
