// `dygslam map` below the command line: the OctoMap of a dataset's static scene, from the SLAM's
// keyframes (inserted with their dynamic masks, local-BA pose corrections and culled keyframes
// applied; the map levelled on the floor it finds) or from given poses (e.g. the ground truth,
// every N-th frame, no masks). Writes OUT/map.bt, map.ot, map_top.png, map_slice.png (and the
// SLAM's trajectory.txt, keyframes.txt; with a reference range reference.bt, ghosts_top.png,
// ghost_cells.txt), each atomically, and prints the summary on stdout.
//
//   MapControllerOptions options;  // filled from the command line
//   MapController controller(options, dataset);  // options.Check(), poses against the range
//   const int exit_code = controller.Run();
#pragma once

#include <chrono>
#include <cstddef>
#include <filesystem>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "core/base/timestamp.h"
#include "core/base/types.h"
#include "core/io/dataset.h"
#include "core/system/system.h"
#include "mapping/keyframe_mapper.h"
#include "mapping/map_compare.h"
#include "mapping/map_frame.h"
#include "mapping/octomap_builder.h"

namespace dygslam {

struct MapControllerOptions {
  std::string dataset_dir;
  SystemOptions system;
  OctoMapOptions octomap;
  size_t first = 0, last = 0;  // rgb.txt entries [first, last)
  std::filesystem::path out;   // the output folder (exists)
  // Build the map from these poses instead of the SLAM (read from `trajectory_path`; every
  // `every`-th frame of the range; Bonn marker-body poses with `bonn_marker`).
  std::optional<std::vector<StampedPose>> given_poses;
  std::string trajectory_path;
  int every = 1;
  bool bonn_marker = false;
  // Also a reference map from the keyframes before this stamp (without masks, final poses), and
  // the ghost voxels of the map against it; `reference_name` names the range in the summary.
  std::optional<Timestamp> reference_until;
  std::string reference_name;
  std::optional<double> save_every_s;  // also write map.bt / map.ot every this many seconds
  bool progress = true;

  // Throws InvalidOptions naming the field.
  void Check() const;
};

// The files `dygslam map` writes into its output folder (with the SLAM's trajectory and keyframes
// unless it maps given poses).
std::vector<std::string> MapOutputNames(bool from_given_poses);

class MapController {
 public:
  // Checks the options, and that the given poses (if any) give a frame of the range a pose
  // (InputError naming the trajectory file otherwise: it is of another sequence).
  MapController(MapControllerOptions options, const RgbdDataset& dataset);

  // Builds the map until the end of the range or a stop signal, writes the outputs, prints the
  // summary. Returns 0, or 1 when the SLAM tracked (almost) nothing. Rethrows an error that
  // stopped the frame loop after writing the outputs of the frames before it.
  int Run();

 private:
  // Keyframes recorded for the reference map: depth kept, final pose tracked.
  struct ReferenceKeyframe {
    Timestamp stamp;
    cv::Mat depth;
    Rigid3d world_from_cam;
    bool removed = false;
  };
  // What writing the map found, for the summary.
  struct MapFigures {
    OctoMapStats stats;
    std::optional<GhostVoxelCounts> ghosts;
    size_t reference_keyframes = 0;
  };

  void OnKeyframe(const KeyframeData& keyframe);
  void AfterFrame(size_t k, TrackingState state);
  void SaveMaps();
  void FeedGivenPoses(const std::function<bool()>& stop_requested);
  void FeedSlam(const std::function<bool()>& stop_requested);
  // SLAM maps: the map levelled (z up, floor at z = 0) on the floor it found.
  void LevelMap();
  MapFigures WriteMaps();
  void WriteReference(OctoMapBuilder& builder, MapFigures* figures);
  void PrintSummary(const MapFigures& figures, double elapsed);
  // Keyframes per second of sequence time against the map stage's capacity.
  void PrintKeyframeRate(const OctoMapStats& stats, const MapperStats& ms, double elapsed) const;
  // How the map frame was levelled (SLAM maps).
  void PrintMapFrame() const;

  MapControllerOptions options_;
  const RgbdDataset& dataset_;
  KeyframeMapper mapper_;
  std::optional<System> system_;
  std::mutex record_mutex_;  // guards the records below (keyframes come from local mapping)
  std::map<int64_t, ReferenceKeyframe> reference_;
  std::vector<Timestamp> keyframe_stamps_;
  std::optional<Rigid3d> first_camera_;
  std::optional<FloorEstimate> floor_;
  Rigid3d map_from_world_;
  size_t processed_ = 0, lost_ = 0, skipped_ = 0, saves_ = 0;
  bool interrupted_ = false;
  std::chrono::steady_clock::time_point t0_, last_save_;
};

}  // namespace dygslam
