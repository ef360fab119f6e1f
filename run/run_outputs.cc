#include "run/run_outputs.h"

#include <cstdio>
#include <filesystem>

#include "core/io/trajectory_io.h"
#include "mapping/keyframe_mapper.h"

namespace dygslam {
namespace fs = std::filesystem;

FrameRow FrameRowFromResult(const FrameResult& result) {
  FrameRow row;
  row.stamp = result.stamp;
  row.state = result.state;
  row.is_keyframe = result.is_keyframe;
  row.num_features = result.num_features;
  row.num_dynamic = result.num_dynamic;
  row.num_tracked = result.num_tracked;
  row.times = result.times;
  return row;
}

std::string FramesCsvHeader() {
  return "stamp,state,keyframe,features,dynamic,tracked,orb_ms,detection_ms,matching_ms,"
         "probability_ms,tracking_ms,total_ms\n";
}

std::string FramesCsvRow(const FrameRow& r) {
  char line[512];
  std::snprintf(line, sizeof(line), "%s,%s,%d,%d,%d,%d,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f\n",
                r.stamp.ToString().c_str(), ToString(r.state), r.is_keyframe ? 1 : 0,
                r.num_features, r.num_dynamic, r.num_tracked, r.times.orb_extraction_ms,
                r.times.detection_ms, r.times.matching_ms, r.times.probability_ms,
                r.times.tracking_ms, r.times.total_ms);
  return line;
}

void WriteSystemTrajectories(const std::string& directory, const System& system) {
  WriteTumTrajectory((fs::path(directory) / "trajectory.txt").string(), system.Trajectory());
  WriteTumTrajectory((fs::path(directory) / "keyframes.txt").string(), system.KeyframeTrajectory());
}

void WriteMapperBinary(const std::string& directory, KeyframeMapper& mapper, bool with_full_map) {
  mapper.Flush();
  mapper.WithBuilder([&](OctoMapBuilder& b) {
    // A continued map (--load-octomap) is written even when no keyframe was added to it.
    if (b.KeyframeIds().empty() && !b.has_base_map()) return;
    b.WriteBinary((fs::path(directory) / "map.bt").string());
    if (with_full_map) b.WriteFull((fs::path(directory) / "map.ot").string());
  });
}

}  // namespace dygslam
