// Recorder component: CameraPose (online poses), Trajectory (slam's final refined trajectories)
// and GroundTruthPose -> TUM files in output_dir, written atomically (temporary file + rename):
//   trajectory.txt           final trajectory of every tracked frame (slam's System::Trajectory()),
//                            or, if slam never sent it (killed / stopped), the online poses
//   keyframes.txt            final keyframe trajectory, or the online poses of keyframe frames
//   frames.csv               per-frame state, counts and stage times (same columns as
//                            `dygslam run --direct`), from CameraPose
//   trajectory_online.txt    poses as published per frame
//   groundtruth.txt          ground truth as published by the player (when received)
// Core: RecorderCore (components/recorder_core.h, no DDS). Shell: RunRecorder ends once both final
// trajectories arrived after slam's COMPONENT_DONE (or 3 s after DONE without them), always
// writing. On stop (SIGINT / SIGTERM) it waits up to flush_timeout_s for slam's final trajectories
// (slam sends them as it stops) while a slam writer is matched, then writes what it has.
#pragma once

#include <cstddef>
#include <memory>
#include <string>

#include "components/component_common.h"
#include "components/recorder_core.h"

namespace dygslam {

namespace dds {
class Participant;
}

struct RecorderStats {
  size_t poses = 0;
  size_t bad_samples = 0;
  // Samples of writers no component of this run announced (components/protocol.h), ignored.
  size_t foreign_samples = 0;
  bool final_trajectory = false;
  std::string trajectory_path;
  // slam left without its end reaching the recorder (this process paused or starved while slam
  // finished, slam killed): the trajectory may lack its last frames.
  bool input_cut_short = false;
  // Per-frame poses of slam that never arrived (gaps in its writer's sequence: they left slam's
  // pose history while this process was paused or starved): frames.csv and the online
  // trajectory lack them.
  size_t poses_missed = 0;
};

RecorderStats RunRecorder(std::shared_ptr<dds::Participant> participant,
                          const RecorderOptions& options, const StopFlagPtr& stop);

}  // namespace dygslam
