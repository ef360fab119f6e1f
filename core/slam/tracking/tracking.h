// Tracking: motion-model and reference-keyframe tracking, local-map tracking, keyframe decision,
// relocalization. One Tracker per camera stream; called from one thread.
#pragma once

#include <deque>
#include <memory>
#include <optional>
#include <vector>

#include "core/base/types.h"
#include "core/slam/feature/matcher.h"
#include "core/slam/local_mapping/local_mapping.h"
#include "core/slam/map/frame.h"
#include "core/slam/map/map.h"
#include "core/slam/map/place_recognition.h"
#include "core/slam/optimize/optimizer.h"
#include "core/slam/tracking/static_depth_odometry.h"

namespace dygslam {

struct TrackingOptions {
  int init_min_features = 300;    // features with depth needed to initialise
  double motion_radius_px = 7.0;  // projection search radius (x scale) for the motion model
  int motion_min_matches = 20;
  int min_inliers = 10;  // motion model / reference keyframe
  int local_map_min_inliers = 30;
  int relocalized_min_inliers = 50;
  int max_frames_between_keyframes = 30;  // usually the frame rate
  double ref_ratio = 0.75;
  int close_tracked_min = 100;
  int close_untracked_min = 70;
  int new_points_min = 100;  // new keyframe: at least this many points from depth
  int local_keyframes_max = 80;
  // Localization mode: the local map is the keyframe sharing the most of the frame's matched
  // points plus its best covisible keyframes, this many keyframes in all (the mapping run's local
  // map, every keyframe observing a matched point, mixes points of other times and drift). 4:
  // best measured on bonn_crowd_part with loop closing on (deterministic final ATE 1/2/3/4/6
  // keyframes: 0.0226/0.0159/0.0154/0.0149/0.0150 m; BENCHMARKS.md, SLAM map files).
  int localization_local_keyframes = 4;
  int relocalization_candidates = 5;
  // The keyframe decision's "tracked close points" include the motion model's temporary points
  // (made from the last frame's depth). true: measured better on bonn_crowd_part (threaded median
  // of 3: 0.0143 vs 0.0154 m); false: ORB-SLAM2's rule (map points only), which keeps making
  // keyframes on long loops where the map thins out (the 61.8 m generated loop is tracked to the
  // end only with false). BENCHMARKS.md, loop closing.
  bool keyframe_counts_odometry_points = true;
  // A keyframe is also due when the frame's map-point inliers fall below this (0: off), whatever
  // the close-point count says. On a long side of the generated 61.8 m loop the temporary points
  // kept the close count at ~500 while the map-point inliers fell by up to 26 a frame, from 591
  // to 37, below local_map_min_inliers (30): lost with no keyframe made. 100 leaves ~3 frames of
  // that decay before the loss (BENCHMARKS.md).
  int keyframe_min_map_inliers = 100;
  PlaceRecognitionOptions place;  // candidates from the BoW index (when a vocabulary is set)
  OptimizerOptions optimizer;
  MatcherOptions matcher;
  // Frames that feature tracking cannot hold get their pose from the dense alignment of their
  // static depth (tracking_fallback.cc); false: such frames are lost.
  bool dense_fallback = true;
  StaticDepthOdometryOptions fallback;
  int fallback_check_below_inliers = 150;  // feature poses with fewer inliers are cross-checked
  // Sampled static pixels seen in both frames (StaticDepthOdometryOptions::verify_step_px) below
  // which a frame's dense pose comes from the estimate constrained by the motion prior, not the
  // plain alignment.
  int fallback_narrow_view_samples = 1600;
  double fallback_override_fraction_gain = 0.02;  // dense agreement must be this much higher
  double fallback_override_rmse_ratio = 1.5;      // ... or higher with this ratio of residuals
  // When features take over again after a stretch of fallback frames, the stretch is re-anchored
  // on the first feature pose (tracking_fallback.cc, SmoothFallbackStretch): the dense pose of the
  // returning frame against the last fallback frame says where that frame should have been, and
  // the stretch (plus the weakly held feature frames just before it) is moved by that correction.
  bool fallback_smoothing = true;
  // Feature frames below this before a stretch join it; the first feature frame after a stretch
  // below this makes no keyframe.
  int fallback_smoothing_weak_inliers = 150;
  double fallback_smoothing_max_translation = 0.15;  // metres: larger corrections are not applied
  double fallback_smoothing_max_rotation_deg = 10.0;
  void Check() const {
    DYGSLAM_CHECK_OPTION(init_min_features > 0, "Tracking.init_min_features");
    DYGSLAM_CHECK_OPTION(motion_radius_px > 0 && motion_radius_px <= 10000,
                         "Tracking.motion_radius_px");
    DYGSLAM_CHECK_OPTION(ref_ratio > 0 && ref_ratio <= 1, "Tracking.ref_ratio");
    DYGSLAM_CHECK_OPTION(localization_local_keyframes >= 1,
                         "Tracking.localization_local_keyframes");
    DYGSLAM_CHECK_OPTION(max_frames_between_keyframes >= 1,
                         "Tracking.max_frames_between_keyframes");
    DYGSLAM_CHECK_OPTION(keyframe_min_map_inliers >= 0, "Tracking.keyframe_min_map_inliers");
    place.Check();
    optimizer.Check();
    matcher.Check();
    // The two fields of `fallback` the settings file sets (Tracking.fallback_*), named as there.
    DYGSLAM_CHECK_OPTION(fallback.min_inlier_fraction > 0 && fallback.min_inlier_fraction <= 1,
                         "Tracking.fallback_min_inlier_fraction");
    DYGSLAM_CHECK_OPTION(fallback.min_inliers >= 1 && fallback.min_inliers <= 10000000,
                         "Tracking.fallback_min_inliers");
    fallback.Check();
    DYGSLAM_CHECK_OPTION(fallback_check_below_inliers >= 0,
                         "Tracking.fallback_check_below_inliers");
    DYGSLAM_CHECK_OPTION(
        fallback_override_fraction_gain >= 0 && fallback_override_fraction_gain <= 1,
        "Tracking.fallback_override_fraction_gain");
    DYGSLAM_CHECK_OPTION(fallback_override_rmse_ratio >= 1,
                         "Tracking.fallback_override_rmse_ratio");
    DYGSLAM_CHECK_OPTION(fallback_smoothing_weak_inliers >= 0,
                         "Tracking.fallback_smoothing_weak_inliers");
    DYGSLAM_CHECK_OPTION(fallback_smoothing_max_translation > 0,
                         "Tracking.fallback_smoothing_max_translation");
    DYGSLAM_CHECK_OPTION(fallback_smoothing_max_rotation_deg > 0,
                         "Tracking.fallback_smoothing_max_rotation_deg");
  }
};

struct TrackResult {
  TrackingState state = TrackingState::kNotInitialized;
  std::optional<Rigid3d> cam_from_world;
  std::shared_ptr<KeyFrame> new_keyframe;  // set when this frame became a keyframe
  int num_inliers = 0;
  // The map point of each feature of the frame (tracked by features; empty otherwise): the
  // dynamic map-point vote (core/slam/map/dynamic_points.h) follows the filter's tracks into them.
  std::vector<std::shared_ptr<MapPoint>> map_points;
};

// A frame's pose stored relative to its reference keyframe, so the trajectory follows the
// keyframes that bundle adjustment refines.
struct TrajectoryRecord {
  Timestamp stamp;
  int64_t ref_kf_id = -1;
  Rigid3d cam_from_ref;
  TrackingState state = TrackingState::kNotInitialized;
  int num_inliers = 0;  // feature inliers of the local-map tracking (0 for fallback frames)
};

class Tracker {
 public:
  Tracker(const TrackingOptions& options, std::shared_ptr<Map> map, LocalMapper& local_mapper);

  // A new keyframe is returned in TrackResult::new_keyframe; the caller hands it to the local
  // mapper (HandOffKeyFrame) after it has announced it, so corrections never precede it.
  TrackResult Track(Frame frame);
  void HandOffKeyFrame(const std::shared_ptr<KeyFrame>& kf);
  // Bag-of-words place recognition: relocalization candidates from `database`, BoW-accelerated
  // matching in relocalization and reference-keyframe tracking; new keyframes get BoW vectors and
  // are added to `database`. Without it (nullptr) both fall back to brute-force matching.
  void SetPlaceRecognition(std::shared_ptr<const Vocabulary> vocabulary,
                           std::shared_ptr<KeyFrameDatabase> database);
  // The map was loaded from a file (map_file.h): the first frame is relocalized against it
  // instead of starting a new map. localization: track against it without adding keyframes or
  // map points (pose only, like ORB-SLAM2's localization mode).
  void StartFromLoadedMap(bool localization);
  // With options.dense_fallback: sets up the dense estimator for images of `camera` now (start-up)
  // rather than on the first frame that needs it.
  void PrepareDenseFallback(const PinholeCamera& camera);

  // World poses of all tracked frames (resolved through current keyframe poses).
  std::vector<StampedPose> Trajectory() const;
  // Active keyframes with id >= min_id (a run on a loaded map: its own keyframes, whose stamps do
  // not interleave with the loaded ones').
  std::vector<StampedPose> KeyframeTrajectory(int64_t min_id = 0) const;
  const std::vector<TrajectoryRecord>& records() const { return records_; }

 private:
  bool Initialize(Frame& frame, TrackResult* result);
  void PrepareLastFrame();
  bool TrackWithMotionModel(Frame& frame);
  bool TrackReferenceKeyFrame(Frame& frame);
  bool Relocalize(Frame& frame);
  bool TrackLocalMap(Frame& frame);
  // A frame after initialization: features (motion model, reference keyframe, relocalization,
  // local map), else the dense fallback, else lost. Called with the map locked.
  void TrackNext(Frame& frame, TrackResult* result);
  // The frame's feature pose accepted: velocity, keyframe decision, the record, the last frame.
  void AcceptFeaturePose(Frame& frame, const std::optional<Rigid3d>& predicted, bool relocalized,
                         TrackResult* result);
  // The frame's dense pose accepted (verified): no keyframe, no map points from it.
  void AcceptDensePose(Frame& frame, TrackResult* result);
  // The newest record is a fallback frame (the frame being tracked follows one).
  bool LastWasFallback() const;
  void UpdateLocalMap(Frame& frame);
  bool NeedNewKeyFrame(const Frame& frame);
  std::shared_ptr<KeyFrame> CreateKeyFrame(Frame& frame);
  // tracking_fallback.cc: the dense estimate of a frame feature tracking could not hold.
  // narrow_only: true only for a pose from the estimate constrained by the motion model (a narrow
  // static view); the frame keeps its feature pose otherwise.
  bool TrackWithStaticDepth(Frame& frame, const std::optional<Rigid3d>& predicted,
                            bool narrow_only = false);
  // A feature pose with fewer than options_.fallback_check_below_inliers inliers is compared with
  // the dense estimate; true (pose replaced by the dense one) when the dense one explains the
  // static depth clearly better.
  bool DenseOverridesFeaturePose(Frame& frame, const std::optional<Rigid3d>& predicted);
  struct DenseResult {
    Rigid3d cam_from_world;
    Rigid3d ref_from_world;
    const DenseView* ref_view = nullptr;
    DepthAgreement agreement;
    bool constrained = false;  // from StaticDepthOdometry::EstimateWithPrior (a narrow view)
  };
  // Too few static pixels seen in both frames for the plain alignment to constrain every
  // direction (TrackingOptions::fallback_narrow_view_samples).
  bool NarrowView(const DepthAgreement& agreement) const;
  // The verified dense pose of a frame (against the last frame, else the newest keyframe;
  // keyframe_only: against the newest keyframe). with_prior: when neither verifies, or the view is
  // narrow (NarrowView), the estimate against the last frame constrained by the motion model
  // (StaticDepthOdometry::EstimateWithPrior).
  std::optional<DenseResult> DenseEstimate(const Frame& frame, const Rigid3d& predicted,
                                           bool keyframe_only, bool with_prior = false);
  // Sets up a frame whose cam_from_world is a dense pose (drops feature associations that
  // disagree with it); true.
  bool AcceptDensePose(Frame& frame);
  // Called for a frame tracked by features right after a fallback frame (last_frame_): re-anchors
  // the fallback stretch on the frame's feature pose (see TrackingOptions::fallback_smoothing).
  // Updates records_ and last_frame_.cam_from_world; false when no verified correction exists.
  bool SmoothFallbackStretch(const Frame& frame, const std::optional<Rigid3d>& predicted);
  void RememberDenseKeyFrame(const std::shared_ptr<KeyFrame>& kf, const Frame& frame);

  TrackingOptions options_;
  std::shared_ptr<Map> map_;
  LocalMapper& local_mapper_;
  Matcher matcher_;
  std::shared_ptr<const Vocabulary> vocabulary_;
  std::shared_ptr<KeyFrameDatabase> database_;
  int64_t frames_seen_ = 0;

  bool initialized_ = false;
  bool lost_ = false;
  bool localization_ = false;
  Frame last_frame_;
  std::optional<Rigid3d> velocity_;  // cam_from_world(t) * world_from_cam(t-1)
  // velocity_ of the last frame whose feature pose rested on enough inliers
  // (>= fallback_smoothing_weak_inliers): the motion prior of the constrained dense estimate, so
  // that a stretch does not carry on the motion of the weakly held frames at its start.
  std::optional<Rigid3d> held_velocity_;
  // The last frames held that way (id, cam_from_world): held_velocity_ is their mean motion per
  // frame, so that one frame's error does not become the stretch's motion.
  std::deque<std::pair<int64_t, Rigid3d>> held_poses_;
  std::shared_ptr<KeyFrame> reference_kf_;
  std::shared_ptr<KeyFrame> last_kf_;
  int64_t last_kf_frame_id_ = -1;
  int64_t last_relocalization_frame_id_ = -1000;
  int last_inliers_ = 0;
  std::vector<std::shared_ptr<KeyFrame>> local_keyframes_;
  std::vector<std::shared_ptr<MapPoint>> local_points_;
  std::vector<TrajectoryRecord> records_;
  std::unique_ptr<StaticDepthOdometry> static_depth_odometry_;  // PrepareDenseFallback / first use
  // The newest keyframe and its dense view: the dense fallback's first reference (its pose is
  // refined by local BA, so fallback frames do not chain the drift of the frames before them).
  std::shared_ptr<KeyFrame> dense_kf_;
  std::shared_ptr<const DenseView> dense_kf_view_;
};

}  // namespace dygslam
