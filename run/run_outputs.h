// What a run writes, written once: frames.csv (one column layout for `dygslam run` in
// every mode: the direct loop and the pipeline's recorder component), the TUM trajectories of a
// System and the map of a KeyframeMapper.
//
// frames.csv: stamp,state,keyframe,features,dynamic,tracked,orb_ms,detection_ms,matching_ms,
//             probability_ms,tracking_ms,total_ms   (stage times in ms, StageTimes)
#pragma once

#include <string>
#include <vector>

#include "core/base/timestamp.h"
#include "core/base/types.h"
#include "core/system/system.h"
#include "mapping/octomap_builder.h"

namespace dygslam {

class KeyframeMapper;  // mapping/keyframe_mapper.h

// One frames.csv line: what the System reported for a frame (FrameResult, or the CameraPose
// message that carries it between components).
struct FrameRow {
  Timestamp stamp;
  TrackingState state = TrackingState::kNotInitialized;
  bool is_keyframe = false;
  int num_features = 0;
  int num_dynamic = 0;
  int num_tracked = 0;
  StageTimes times;
};

FrameRow FrameRowFromResult(const FrameResult& result);
std::string FramesCsvHeader();
std::string FramesCsvRow(const FrameRow& row);

// DIR/trajectory.txt (every tracked frame, refined) and DIR/keyframes.txt; atomically.
void WriteSystemTrajectories(const std::string& directory, const System& system);
// Waits for the mapper's queue, then writes DIR/map.bt when the map has a keyframe or a loaded
// base map (and DIR/map.ot, the OctoMap with probabilities, with `with_full_map`).
void WriteMapperBinary(const std::string& directory, KeyframeMapper& mapper,
                       bool with_full_map = false);

// The static map of a SLAM map file (--load-map) as DIR/map.bt, for a run that added no keyframe
// of its own (--localization): the file's map points, each inserted by ray casting from the
// centre of every keyframe that observes it (free space cleared along the ray), with the sensor
// model and range of `octomap`. The map file is read against `options` like CheckMapFile. Returns
// the number of map points inserted (0: nothing written).
size_t WriteMapFileOctoMap(const std::string& directory, const std::string& map_file,
                           const SystemOptions& options, const OctoMapOptions& octomap,
                           bool with_full_map = false);

}  // namespace dygslam
