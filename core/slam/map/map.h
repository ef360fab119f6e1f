// Map points, keyframes, covisibility graph.
//
// Concurrency: tracking and local mapping share the map. Every read or write of a keyframe's or
// map point's mutable state (pose, position, observations, connections, flags) happens while
// holding Map::mutex() — a single map lock, held briefly by each thread (local bundle adjustment
// copies its problem out and solves without the lock). Immutable feature data of keyframes
// (keypoints, descriptors, depth) can be read without it. Objects are shared via shared_ptr;
// nothing is deleted while another thread may hold it.
#pragma once

#include <Eigen/Core>
#include <atomic>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <vector>

#include "core/base/rigid3.h"
#include "core/base/timestamp.h"
#include "core/slam/map/frame.h"
#include "core/slam/feature/orb_extractor.h"

namespace dygslam {

class KeyFrame;

class MapPoint {
 public:
  MapPoint(int64_t id, const Eigen::Vector3d& position, int64_t first_kf_id)
      : id(id), position(position), first_kf_id(first_kf_id) {
    ++live_count_;
  }
  ~MapPoint() { --live_count_; }
  MapPoint(const MapPoint&) = delete;
  MapPoint& operator=(const MapPoint&) = delete;
  // Objects alive in the process (in the map or still referenced elsewhere): a leak check.
  static int64_t LiveCount() { return live_count_.load(); }

  const int64_t id;
  Eigen::Vector3d position;
  Descriptor descriptor{};
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  // mean viewing direction (unit)
  double min_distance = 0, max_distance = 0;         // scale-invariance distances
  std::map<int64_t, int> observations;               // keyframe id -> keypoint index
  int64_t ref_kf_id = -1;
  const int64_t first_kf_id;
  int visible_count = 1;  // times predicted visible in a tracked frame
  int found_count = 1;    // times actually matched
  bool bad = false;
  std::shared_ptr<MapPoint> replaced_by;
  // Dynamic-feature evidence (core/slam/map/dynamic_points.h): votes from the filter's labels of the
  // features that continue this point's track; is_dynamic: flagged (and taken out of the map).
  int dynamic_votes = 0;
  int static_votes = 0;
  bool is_dynamic = false;

  // Tracking scratch (tracking thread only).
  int64_t last_frame_seen = -1;
  int64_t track_reference_for_frame = -1;
  bool track_in_view = false;
  double track_proj_x = 0, track_proj_y = 0, track_proj_xr = 0, track_view_cos = 0;
  int track_scale_level = 0;
  // Local mapping scratch.
  int64_t fuse_candidate_for_kf = -1;
  int64_t ba_local_for_kf = -1;

  int NumObservations() const { return static_cast<int>(observations.size()); }
  double FoundRatio() const { return static_cast<double>(found_count) / visible_count; }
  int PredictScale(double distance, const CameraGeometry& g) const;

 private:
  static inline std::atomic<int64_t> live_count_{0};
};

class KeyFrame {
 public:
  KeyFrame(int64_t id, const Frame& frame);
  ~KeyFrame() { --live_count_; }
  KeyFrame(const KeyFrame&) = delete;
  KeyFrame& operator=(const KeyFrame&) = delete;
  static int64_t LiveCount() { return live_count_.load(); }

  const int64_t id;
  const int64_t frame_id;
  const Timestamp stamp;
  const std::shared_ptr<const CameraGeometry> geometry;
  const std::vector<cv::KeyPoint> keypoints;
  const std::vector<cv::KeyPoint> undistorted;
  const std::vector<Descriptor> descriptors;
  const std::vector<float> depth;
  const std::vector<float> u_right;
  const std::vector<uint8_t> in_dynamic_region;
  const FeatureGrid grid;
  const BowVector bow_vector;  // copied from the frame (empty without a vocabulary)
  const FeatureVector bow_features;
  bool CanSeedPoint(size_t i) const { return depth[i] > 0 && !in_dynamic_region[i]; }

  // Mutable state, guarded by Map::mutex().
  Rigid3d cam_from_world;
  std::vector<std::shared_ptr<MapPoint>> map_points;
  std::map<int64_t, int> connection_weights;  // covisible keyframe id -> shared points
  std::vector<int64_t> ordered_connections;   // by weight, descending
  int64_t parent_id = -1;
  bool bad = false;
  bool not_erase = false;
  Rigid3d cam_from_parent;  // set when culled: this keyframe relative to its parent
  // Local mapping scratch.
  int64_t ba_local_for_kf = -1, ba_fixed_for_kf = -1, fuse_target_for_kf = -1;
  int64_t track_reference_for_frame = -1;

  size_t size() const { return keypoints.size(); }
  Eigen::Vector3d CameraCenter() const { return cam_from_world.Inverse().translation; }
  std::vector<int64_t> BestCovisibles(int n) const;
  int NumTrackedPoints(int min_observations) const;
  Eigen::Vector3d UnprojectWorld(size_t i) const;

 private:
  static inline std::atomic<int64_t> live_count_{0};
};

// Sizes of the map, for memory monitoring.
struct MapStatistics {
  size_t keyframes = 0;               // active
  size_t culled_keyframes = 0;        // kept as parent + relative pose only
  size_t map_points = 0;              // in the map
  int64_t live_keyframe_objects = 0;  // alive in the process (map + anything still holding one)
  int64_t live_point_objects = 0;
};

class Map {
 public:
  std::mutex& mutex() const { return mutex_; }

  int64_t NextKeyFrameId() { return next_kf_id_++; }
  int64_t NextMapPointId() { return next_point_id_++; }
  // The id counters, for map files (a continued map keeps counting where it stopped).
  int64_t PeekNextKeyFrameId() const { return next_kf_id_; }
  int64_t PeekNextMapPointId() const { return next_point_id_; }
  void SetIdCounters(int64_t next_kf_id, int64_t next_point_id) {
    next_kf_id_ = next_kf_id;
    next_point_id_ = next_point_id;
  }

  void AddKeyFrame(const std::shared_ptr<KeyFrame>& kf);
  void AddMapPoint(const std::shared_ptr<MapPoint>& mp);
  std::shared_ptr<KeyFrame> GetKeyFrame(int64_t id) const;  // active keyframes only
  const std::map<int64_t, std::shared_ptr<KeyFrame>>& keyframes() const { return keyframes_; }
  const std::map<int64_t, std::shared_ptr<MapPoint>>& map_points() const { return points_; }
  size_t NumKeyFrames() const { return keyframes_.size(); }
  size_t NumMapPoints() const { return points_.size(); }
  MapStatistics Statistics() const;  // locks the map mutex

  // Observation bookkeeping.
  void AddObservation(const std::shared_ptr<MapPoint>& mp, const std::shared_ptr<KeyFrame>& kf,
                      int idx);
  void EraseObservation(const std::shared_ptr<MapPoint>& mp, int64_t kf_id);
  void SetBad(const std::shared_ptr<MapPoint>& mp);
  // Replaces `mp` by `other` in every keyframe that observes it.
  void Replace(const std::shared_ptr<MapPoint>& mp, const std::shared_ptr<MapPoint>& other);
  void UpdateNormalAndDepth(MapPoint& mp) const;
  void ComputeDistinctiveDescriptor(MapPoint& mp) const;
  // Recomputes covisibility weights of kf (and its neighbours' links to it).
  void UpdateConnections(const std::shared_ptr<KeyFrame>& kf);
  // Culls a keyframe: detaches observations, re-links children to a parent.
  void SetBad(const std::shared_ptr<KeyFrame>& kf);
  // cam_from_world of any keyframe ever created (culled ones via their parent chain).
  Rigid3d ResolvedPose(int64_t kf_id) const;
  bool IsCulled(int64_t kf_id) const { return culled_.count(kf_id) > 0; }
  // The active keyframe that stands for `kf_id`: itself while active, else the first active one up
  // the parents of culled keyframes (-1 for an id the map never had).
  int64_t ActiveKeyFrameId(int64_t kf_id) const;
  // Changes whenever a loop correction or global bundle adjustment moved the whole map: an
  // optimisation that copied poses before must not write them back (they are stale).
  int64_t CorrectionEpoch() const { return correction_epoch_.load(); }
  void BumpCorrectionEpoch() { ++correction_epoch_; }

 private:
  mutable std::mutex mutex_;
  int64_t next_kf_id_ = 0, next_point_id_ = 0;
  std::atomic<int64_t> correction_epoch_{0};
  std::map<int64_t, std::shared_ptr<KeyFrame>> keyframes_;  // active
  // Culled keyframes keep only what the trajectory needs (their parent and the relative pose),
  // so memory does not grow with the features of keyframes that are gone.
  struct CulledKeyFrame {
    int64_t parent_id;
    Rigid3d cam_from_parent;
  };
  std::map<int64_t, CulledKeyFrame> culled_;
  std::map<int64_t, std::shared_ptr<MapPoint>> points_;
};

}  // namespace dygslam
