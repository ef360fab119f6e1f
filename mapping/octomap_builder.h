// Occupancy map (OctoMap) of the static scene, built from the keyframes the SLAM emits.
//
//   OctoMapBuilder builder(camera, options);  // a keyframe stream: KeyframeConsumer owns one
//   builder.Insert(keyframe);                 // static part of the keyframe, free space ray-cast
//   builder.UpdatePoses({{id, world_from_cam}, ...});   // after loop closure / BA
//   builder.Remove(id);                       // culled keyframe
//   builder.WriteBinary("map.bt");  builder.WriteFull("map.ot");
//
// What goes in: every valid depth pixel (min_range <= depth, finite) that is not dynamic, i.e. not
// inside the dilated KeyframeData::dynamic_mask and not within dynamic_keypoint_radius_px of a
// keypoint flagged in KeyframeData::keypoint_dynamic. Pixels are sampled with pixel_stride,
// back-projected with the pinhole model (depth is the z coordinate; the depth image is assumed
// registered and undistorted, as in TUM/Bonn), and reduced by a voxel grid (centroid per cell) in
// the camera frame. The cloud is transformed by world_from_cam and inserted with
// the updates of octomap::OcTree::insertPointCloud from the camera centre (ScanInserter,
// scan_inserter.h), so the cells along each beam are updated as free and the end cell as occupied;
// beams longer than max_range clear space up to max_range only.
//
// Pose corrections: the builder keeps each keyframe's downsampled static cloud (camera frame,
// a few thousand points) and its pose. The OcTree is a cache derived from them. When
// UpdatePoses() moves a keyframe by more than the rebuild threshold (the displacement of a point
// at max_range: |dt| + angle * max_range > rebuild_displacement, default half a voxel), or a
// keyframe is removed, the tree is marked stale and rebuilt from scratch from all stored
// keyframes (in their original insertion order) the next time it is read. Why a full rebuild and
// not "subtract the old scan, add the new one": OctoMap's log-odds updates are clamped
// (clamping_min/max) and each scan gives occupied cells priority over free ones, so a scan's
// contribution cannot be subtracted exactly; a rebuild is exact, deterministic and, with
// downsampled clouds, cheap (a few ms per keyframe). Corrections below the threshold only update
// the stored pose (the cells would move by less than half a voxel) and are applied with the
// next rebuild. Several corrections in a row (loop closure + culling) cost one rebuild, because
// the rebuild is deferred until the map is read (tree(), Stats(), Write*()) or Sync() is called.
// New keyframes are inserted into the tree right away even while a rebuild is pending (the map
// stays live; what is stale are the cells of the moved keyframes). KeyframeMapper bounds the
// share of time spent on rebuilds when the SLAM corrects poses after every keyframe.
//
// Not thread-safe: one owner thread calls all methods.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <map>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "core/base/camera.h"
#include "core/base/rigid3.h"
#include "core/base/types.h"
#include "mapping/octomap_file.h"

namespace octomap {
class OcTree;
}

namespace dygslam {

class ScanInserter;

struct OctoMapOptions {
  // Leaf size in metres.
  double resolution = 0.05;
  // Depth beyond max_range: free space is cleared up to max_range, no occupied end cell.
  // Kinect-class depth noise grows ~quadratically; 4 m keeps it below ~4 cm.
  double max_range = 4.0;
  // Depth below this is no measurement (Kinect v1/v2 and Xtion cannot see closer than ~0.4 m).
  double min_range = 0.3;
  // OctoMap sensor model (its defaults).
  double prob_hit = 0.7;
  double prob_miss = 0.4;
  double clamping_min = 0.12;
  double clamping_max = 0.97;
  double occupancy_threshold = 0.5;
  // Use every pixel_stride-th pixel in u and v (1 = all).
  int pixel_stride = 2;
  // Voxel-grid filter before insertion: one point (the centroid) per cell of the map's
  // resolution, in the camera frame. Rays to points of one cell end in the same voxel, so
  // finer cells only cost time.
  bool use_voxel_filter = true;
  // Leave out dynamic pixels (dynamic_mask and dynamic keypoints). false = the 'no filter'
  // baseline: every valid depth pixel goes in.
  bool use_dynamic_mask = true;
  // Grow dynamic_mask by this many pixels (elliptic kernel) before use: mask edges and the depth
  // edges of people do not line up exactly.
  int dynamic_mask_dilation_px = 5;
  // Disk around each keypoint flagged dynamic that is left out, in pixels (0 = ignore flags).
  int dynamic_keypoint_radius_px = 8;
  // OctoMap: skip the inner-node update per scan and do it once before the tree is read.
  bool lazy_eval = true;
  // Rebuild when a pose correction moves a point at max_range by more than this (metres).
  // <= 0 means half a voxel.
  double rebuild_displacement = 0.0;

  double EffectiveRebuildDisplacement() const {
    return rebuild_displacement > 0 ? rebuild_displacement : 0.5 * resolution;
  }
  void Check() const;
};

struct OctoMapStats {
  size_t num_keyframes = 0;
  size_t num_stored_points = 0;  // static points kept for rebuilds (all keyframes)
  size_t num_leaves = 0;         // leaves of the (pruned) tree
  size_t num_occupied_leaves = 0;
  size_t num_free_leaves = 0;
  // The same in cells of `resolution` (a pruned leaf of size 2^k * res counts 8^k).
  uint64_t num_occupied_voxels = 0;
  uint64_t num_free_voxels = 0;
  size_t memory_bytes = 0;    // octomap::OcTree::memoryUsage()
  size_t num_insertions = 0;  // octree insertions (incremental + during rebuilds)
  size_t num_rebuilds = 0;
  double last_insert_ms = 0;    // last incremental Insert() (filtering + ray casting)
  double median_insert_ms = 0;  // over incremental Insert() calls (wall time)
  // The same in CPU time of the inserting thread: what insertion costs when other processes
  // share the cores.
  double median_insert_cpu_ms = 0;
  double last_rebuild_ms = 0;
  double last_rebuild_cpu_ms = 0;
};

// Result of preparing one keyframe (exposed for tests and tools).
struct StaticCloud {
  std::vector<Eigen::Vector3f> points_cam;  // downsampled, camera frame
  size_t num_valid_pixels = 0;              // sampled pixels with usable depth
  size_t num_dynamic_pixels = 0;            // of those, left out as dynamic
};

// Filtering + back-projection + voxel grid of one keyframe for `camera` and `options`: what
// OctoMapBuilder::Insert stores of it. Thread-safe (reads only its arguments); InputError names
// the keyframe and the field (depth/mask of the wrong type or size).
StaticCloud ExtractStaticCloud(const KeyframeData& keyframe, const PinholeCamera& camera,
                               const OctoMapOptions& options);

class OctoMapBuilder {
 public:
  // Throws InvalidOptions if camera or options fail Check().
  OctoMapBuilder(const PinholeCamera& camera, const OctoMapOptions& options = {});
  ~OctoMapBuilder();
  OctoMapBuilder(const OctoMapBuilder&) = delete;
  OctoMapBuilder& operator=(const OctoMapBuilder&) = delete;

  // Inserts the static part of a new keyframe. If the id is already known and depth is empty,
  // only its pose is updated (as UpdatePoses); if depth is given, the keyframe is replaced.
  // A keyframe stream (new / pose update / removed) is applied by KeyframeConsumer
  // (mapping/keyframe_consumer.h): a removed or pose_update_only keyframe here is an InputError,
  // as are depth/mask of the wrong type or size and a non-finite pose (the message names the
  // keyframe id and the field).
  void Insert(const KeyframeData& keyframe);
  // The same with the keyframe's static cloud already extracted (ExtractStaticCloud with this
  // builder's camera and options): the keyframe's images are not read and may be released, so a
  // stage ahead of the map can keep clouds (~30 KB) queued instead of images (~2.4 MB).
  void Insert(const KeyframeData& keyframe, StaticCloud cloud);

  // Sets the poses of known keyframes (unknown ids are ignored; returns how many were known).
  // Schedules a full rebuild if any keyframe moved by more than the rebuild threshold.
  size_t UpdatePoses(const std::map<int64_t, Rigid3d>& world_from_cam);

  // Removes a keyframe's contribution (schedules a rebuild). Returns false if unknown.
  bool Remove(int64_t keyframe_id);

  // Continues an existing map: the tree starts from `base` (e.g. a previous run's
  // map.ot; a .bt works too but has lost the probabilities) and keyframes are inserted on top;
  // rebuilds start from it again. Throws InputError naming `source` when its resolution differs
  // from OctoMap.resolution. Call before the first Insert.
  void SetBaseMap(const octomap::OcTree& base, const std::string& source);
  bool has_base_map() const { return base_ != nullptr; }

  // Brings the tree up to date (rebuild if scheduled, inner nodes if lazy).
  void Sync();
  // The map of the final poses: rebuilds when any keyframe's pose differs at all from the pose it
  // was inserted with (corrections below the rebuild threshold included), then Sync(). The tree
  // is then what inserting every keyframe at its current pose, in insertion order, gives, whatever
  // rebuilds happened during the run and when: the map written at the end of a run depends on the
  // keyframes and their final poses only.
  void Finalize();
  bool rebuild_pending() const { return rebuild_pending_; }

  // The map, synchronised first.
  const octomap::OcTree& tree();
  OctoMapStats Stats();

  bool Contains(int64_t keyframe_id) const { return keyframes_.count(keyframe_id) > 0; }
  std::vector<int64_t> KeyframeIds() const;
  // Stored pose of a keyframe; throws std::out_of_range if unknown.
  const Rigid3d& Pose(int64_t keyframe_id) const;

  // Atomic writes (temporary file in the same directory + rename). Throws InputError naming the
  // file on failure. .bt = max-likelihood binary, .ot = full probabilities.
  void WriteBinary(const std::string& path);
  void WriteFull(const std::string& path);

  const OctoMapOptions& options() const { return options_; }
  const PinholeCamera& camera() const { return camera_; }

  // Filtering + back-projection + voxel grid of one keyframe, without touching the map.
  StaticCloud ExtractStaticCloud(const KeyframeData& keyframe) const;

 private:
  struct StoredKeyframe {
    uint64_t sequence = 0;  // insertion order
    Rigid3d world_from_cam;
    Rigid3d inserted_world_from_cam;  // pose the tree currently reflects
    std::vector<Eigen::Vector3f> points_cam;
  };

  // InputError for a removed / pose_update_only keyframe or a non-finite pose.
  static void CheckInsertable(const KeyframeData& keyframe);
  // Insert with the cloud given (or extracted here when not).
  void InsertCloud(const KeyframeData& keyframe, std::optional<StaticCloud> cloud);
  void InsertIntoTree(const StoredKeyframe& keyframe);
  void Rebuild();
  void ResetTree();
  bool NeedsRebuild(const Rigid3d& a, const Rigid3d& b) const;

  PinholeCamera camera_;
  OctoMapOptions options_;
  std::unique_ptr<octomap::OcTree> tree_;
  std::unique_ptr<octomap::OcTree> base_;   // SetBaseMap: what every (re)build starts from
  std::unique_ptr<ScanInserter> inserter_;  // reused grid of the scan's cells
  std::map<int64_t, StoredKeyframe> keyframes_;
  uint64_t next_sequence_ = 0;
  bool rebuild_pending_ = false;
  bool inner_dirty_ = false;
  std::vector<double> insert_ms_;
  std::vector<double> insert_cpu_ms_;
  double last_insert_ms_ = 0;
  double last_rebuild_ms_ = 0;
  double last_rebuild_cpu_ms_ = 0;
  size_t num_insertions_ = 0;
  size_t num_rebuilds_ = 0;
};

}  // namespace dygslam
