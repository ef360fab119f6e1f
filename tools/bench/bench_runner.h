// One benchmark run of `dygslam bench`: a configuration (a System filter mode, or the RGB-D
// odometry baseline) over a range of a dataset's frames, its outputs written to a folder, and the
// scoring of that folder against the ground truth.
//
// `dygslam bench` runs each run in its own process (clean peak memory); the process calls
// RunSystemOnSequence / RunOdometryOnSequence and WriteRunOutput, the parent calls ScoreRun.
//
// Run folder:
//   trajectory.txt  TUM trajectory (world_from_cam) of every frame with a pose
//   frames.csv      one line per frame: stamp,ok,orb_ms,detection_ms,detection_wait_ms,
//                   matching_ms,probability_ms,tracking_ms,local_mapping_ms,total_ms,top_up_ms
//   summary.txt     "key value" lines: frames, lost, loop_seconds
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "core/io/dataset.h"
#include "core/system/system.h"
#include "run/run_outputs.h"
#include "tools/bench/bench_report.h"
#include "tools/bench/rgbd_odometry_baseline.h"

namespace dygslam {

struct RunOutput {
  std::vector<StampedPose> trajectory;
  // Every processed frame as frames.csv has it (baseline: state ok or lost, total_ms only).
  std::vector<FrameRow> rows;
  int frames = 0;
  int lost = 0;
  double loop_seconds = 0;
};

// Called after each frame with (frames done, frames to do).
using RunProgress = std::function<void(size_t, size_t)>;

// rgb.txt entries [first, last) (last clamped to the number of entries; entries without a
// depth partner are skipped). Throws InvalidOptions for an empty range.
RunOutput RunSystemOnSequence(const RgbdDataset& dataset, const SystemOptions& options,
                              size_t first, size_t last, const RunProgress& progress = {});
RunOutput RunOdometryOnSequence(const RgbdDataset& dataset, const PinholeCamera& camera,
                                double depth_map_factor, const RgbdOdometryOptions& options,
                                size_t first, size_t last, const RunProgress& progress = {});

// Writes the run folder (created if needed); every file atomically.
void WriteRunOutput(const std::string& directory, const RunOutput& output);

// Reads a run folder and scores it: ATE against `groundtruth` with the `dygslam eval` defaults,
// mean stage times, frames/lost/loop time. sequence/config/run/peak memory are left to the
// caller. Throws InputError naming the file.
BenchRun ScoreRun(const std::string& directory, const std::vector<StampedPose>& groundtruth);

// Mean of every stage over the frames (zeros for an empty input).
StageMeans MeanStageTimes(const std::vector<StageTimes>& times);

// "FIRST:LAST" (either side may be empty) -> [first, last) clamped to `total`. Throws
// InvalidOptions for malformed text or an empty range.
// ParseFrameRange: core/io/dataset.h

}  // namespace dygslam
