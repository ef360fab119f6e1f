// RecorderCore: the recorder component's work without DDS. slam's CameraPose messages (online
// poses, frames.csv rows), its final Trajectory messages and the player's GroundTruthPose ->
// the TUM files and frames.csv of a run (see recorder.h for the files), written atomically. The
// shell (recorder.h) reads the topics and decides when the run is over.
#pragma once

#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/base/timestamp.h"
#include "core/base/types.h"
#include "dygslam_msg/CameraPose.h"
#include "dygslam_msg/GroundTruth.h"
#include "dygslam_msg/Trajectory.h"
#include "run/run_outputs.h"

namespace dygslam {

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
  // Writes the files (see above). Returns the trajectory.txt path; "" when no frame came and an
  // earlier run's trajectory.txt is there (then nothing but the ground-truth copy is written: the
  // earlier run's files stay).
  std::string Write() const;

 private:
  void WriteGroundTruthCopy(const std::filesystem::path& path) const;
  RecorderOptions options_;
  std::vector<StampedPose> online_;
  std::vector<StampedPose> online_keyframes_;
  std::vector<FrameRow> frame_rows_;  // frames.csv rows, in the order they came
  size_t num_lost_ = 0;
  std::vector<StampedPose> ground_truth_;
  std::optional<std::vector<StampedPose>> final_frames_, final_keyframes_;
  // OUTPUT/groundtruth.txt was there before this recorder and is no copy an earlier recorder wrote
  // (a user's file): it is left as it was, with a warning unless it holds this ground truth.
  bool ground_truth_file_existed_ = false;
};

}  // namespace dygslam
