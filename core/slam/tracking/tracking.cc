#include "core/slam/tracking/tracking.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <opencv2/calib3d.hpp>
#include <set>

#include "core/slam/tracking/relocalization.h"

namespace dygslam {

Tracker::Tracker(const TrackingOptions& options, std::shared_ptr<Map> map,
                 LocalMapper& local_mapper)
    : options_(options),
      map_(std::move(map)),
      local_mapper_(local_mapper),
      matcher_(options.matcher) {
  options_.Check();
}

TrackResult Tracker::Track(Frame frame) {
  TrackResult result;
  ++frames_seen_;
  // A local BA due before this frame lands now (the schedule:
  // core/slam/local_mapping/local_mapping.h).
  local_mapper_.BeginFrame(frame.id);
  std::unique_lock<std::mutex> lock(map_->mutex());
  if (initialized_) {
    TrackNext(frame, &result);
  } else if (Initialize(frame, &result)) {
    initialized_ = true;
    RememberDenseKeyFrame(result.new_keyframe, frame);
    result.map_points = frame.map_points;
    last_frame_ = frame;
  }
  return result;
}

void Tracker::TrackNext(Frame& frame, TrackResult* result) {
  bool ok = false;
  bool relocalized = false;
  std::optional<Rigid3d> predicted;  // motion model: the seed of the dense fallback
  if (!lost_) {
    PrepareLastFrame();
    if (last_frame_.has_pose)
      predicted = velocity_ ? *velocity_ * last_frame_.cam_from_world : last_frame_.cam_from_world;
    if (last_frame_.has_pose && velocity_ && frame.id > last_relocalization_frame_id_ + 1 &&
        !LastWasFallback())
      frame.motion_prior = predicted;
    if (velocity_ && frame.id > last_relocalization_frame_id_ + 1) ok = TrackWithMotionModel(frame);
    if (!ok) ok = TrackReferenceKeyFrame(frame);
  }
  if (!ok) {
    frame.motion_prior.reset();
    ok = Relocalize(frame);
    relocalized = ok;
  }
  if (ok) ok = TrackLocalMap(frame);
  // A pose held by few features is checked against the dense estimate (tracking_fallback.cc).
  // Right after a fallback frame, a pose held by few features (< fallback_smoothing_weak_inliers)
  // where the static view is still a strip beside the person leaving it can be centimetres off:
  // there the dense chain continues (estimate constrained by the motion model), and the stretch
  // is re-anchored on the next feature pose (SmoothFallbackStretch).
  const bool dense_continues = ok && options_.dense_fallback && LastWasFallback() &&
                               last_inliers_ < options_.fallback_smoothing_weak_inliers &&
                               TrackWithStaticDepth(frame, predicted, true);
  const bool dense_override = dense_continues || (ok && options_.dense_fallback &&
                                                  DenseOverridesFeaturePose(frame, predicted));
  if (ok && !dense_override) {
    AcceptFeaturePose(frame, predicted, relocalized, result);
  } else if (dense_override ||
             (options_.dense_fallback && TrackWithStaticDepth(frame, predicted))) {
    // Features take over again as soon as they hold the pose (the next frame tries them first).
    AcceptDensePose(frame, result);
  } else {
    lost_ = true;
    velocity_.reset();
    held_velocity_.reset();
    held_poses_.clear();
    result->state = TrackingState::kLost;
    records_.push_back({frame.stamp, -1, Rigid3d(), TrackingState::kLost});
    frame.has_pose = false;
    last_frame_ = frame;
  }
}

void Tracker::AcceptFeaturePose(Frame& frame, const std::optional<Rigid3d>& predicted,
                                bool relocalized, TrackResult* result) {
  lost_ = false;
  const bool returning = LastWasFallback();
  if (options_.dense_fallback && options_.fallback_smoothing && returning)
    SmoothFallbackStretch(frame, predicted);
  result->state = relocalized ? TrackingState::kRelocalized : TrackingState::kOk;
  result->cam_from_world = frame.cam_from_world;
  result->num_inliers = last_inliers_;
  velocity_ =
      last_frame_.has_pose
          ? std::optional<Rigid3d>(frame.cam_from_world * last_frame_.cam_from_world.Inverse())
          : std::nullopt;
  if (last_inliers_ >= options_.fallback_smoothing_weak_inliers) {
    // The mean motion per frame over the last frames held by enough inliers (at most 10 frames
    // apart).
    held_poses_.emplace_back(frame.id, frame.cam_from_world);
    while (held_poses_.size() > 1 &&
           (held_poses_.size() > 10 || frame.id - held_poses_.front().first > 10))
      held_poses_.pop_front();
    if (held_poses_.size() > 1) {
      const double n = double(frame.id - held_poses_.front().first);
      const Rigid3d total = frame.cam_from_world * held_poses_.front().second.Inverse();
      held_velocity_ = Rigid3d(Eigen::Quaterniond::Identity().slerp(1.0 / n, total.rotation),
                               total.translation / n);
    } else {
      held_velocity_ = velocity_;
    }
  }
  // Points matched as outliers are dropped before the frame becomes "last".
  for (size_t i = 0; i < frame.size(); ++i) {
    if (frame.outlier[i]) frame.map_points[i] = nullptr;
  }
  // The first feature pose after a fallback stretch held by few inliers can be centimetres off
  // (bonn_crowd_part entry 206: 86 inliers, 5 cm): it makes no keyframe, so no later frame and
  // no new point hangs on it; the next frames (features back, or the fallback) decide.
  const bool weak_return = returning && last_inliers_ < options_.fallback_smoothing_weak_inliers;
  if (!localization_ && !weak_return && NeedNewKeyFrame(frame))
    result->new_keyframe = CreateKeyFrame(frame);
  if (result->new_keyframe) RememberDenseKeyFrame(result->new_keyframe, frame);
  result->map_points = frame.map_points;
  records_.push_back({frame.stamp, reference_kf_->id,
                      frame.cam_from_world * reference_kf_->cam_from_world.Inverse(), result->state,
                      last_inliers_});
  last_frame_ = frame;
}

bool Tracker::LastWasFallback() const {
  return !records_.empty() && records_.back().state == TrackingState::kFallback;
}

void Tracker::AcceptDensePose(Frame& frame, TrackResult* result) {
  lost_ = false;
  result->state = TrackingState::kFallback;
  result->cam_from_world = frame.cam_from_world;
  result->num_inliers = 0;
  velocity_ = frame.cam_from_world * last_frame_.cam_from_world.Inverse();
  records_.push_back({frame.stamp, reference_kf_->id,
                      frame.cam_from_world * reference_kf_->cam_from_world.Inverse(),
                      result->state});
  last_frame_ = frame;
}

void Tracker::SetPlaceRecognition(std::shared_ptr<const Vocabulary> vocabulary,
                                  std::shared_ptr<KeyFrameDatabase> database) {
  vocabulary_ = std::move(vocabulary);
  database_ = std::move(database);
}

void Tracker::StartFromLoadedMap(bool localization) {
  localization_ = localization;
  // An empty loaded map is extended from scratch, or (localization) never gives a pose.
  initialized_ = localization || map_->NumKeyFrames() > 0;
  lost_ = initialized_;  // no pose yet: relocalize the first frame
}

void Tracker::HandOffKeyFrame(const std::shared_ptr<KeyFrame>& kf) {
  local_mapper_.InsertKeyFrame(kf);
}

bool Tracker::Initialize(Frame& frame, TrackResult* result) {
  int with_depth = 0;
  for (float d : frame.depth) with_depth += d > 0;
  if (with_depth < options_.init_min_features) {
    result->state = TrackingState::kNotInitialized;
    records_.push_back({frame.stamp, -1, Rigid3d(), TrackingState::kNotInitialized});
    return false;
  }
  frame.cam_from_world = Rigid3d::Identity();
  frame.has_pose = true;
  if (vocabulary_) frame.ComputeBow(*vocabulary_);
  auto kf = std::make_shared<KeyFrame>(map_->NextKeyFrameId(), frame);
  map_->AddKeyFrame(kf);
  if (database_) database_->Add(kf->id, kf->bow_vector);
  for (size_t i = 0; i < frame.size(); ++i) {
    if (!frame.CanSeedPoint(i)) continue;
    auto mp = std::make_shared<MapPoint>(map_->NextMapPointId(), frame.UnprojectWorld(i), kf->id);
    mp->ref_kf_id = kf->id;
    map_->AddObservation(mp, kf, static_cast<int>(i));
    map_->ComputeDistinctiveDescriptor(*mp);
    map_->UpdateNormalAndDepth(*mp);
    map_->AddMapPoint(mp);
    frame.map_points[i] = mp;
  }
  reference_kf_ = kf;
  last_kf_ = kf;
  last_kf_frame_id_ = frame.id;
  local_keyframes_ = {kf};
  result->state = TrackingState::kOk;
  result->cam_from_world = frame.cam_from_world;
  result->new_keyframe = kf;
  result->num_inliers = static_cast<int>(map_->NumMapPoints());
  records_.push_back({frame.stamp, kf->id, Rigid3d::Identity(), TrackingState::kOk});
  return true;
}

void Tracker::PrepareLastFrame() {
  // Follow replaced points, drop culled ones, refresh the pose from the reference keyframe and
  // add temporary "visual odometry" points from the last frame's depth (close points first).
  for (auto& mp : last_frame_.map_points) {
    if (!mp) continue;
    int guard = 0;
    while (mp && mp->replaced_by && guard++ < 100) mp = mp->replaced_by;
    if (mp && mp->bad) mp = nullptr;
  }
  if (!records_.empty() && records_.back().ref_kf_id >= 0) {
    const TrajectoryRecord& r = records_.back();
    last_frame_.cam_from_world = r.cam_from_ref * map_->ResolvedPose(r.ref_kf_id);
  }
  std::vector<std::pair<float, size_t>> by_depth;
  for (size_t i = 0; i < last_frame_.size(); ++i) {
    if (last_frame_.CanSeedPoint(i)) by_depth.push_back({last_frame_.depth[i], i});
  }
  std::sort(by_depth.begin(), by_depth.end());
  int added = 0;
  for (const auto& [d, i] : by_depth) {
    const auto& mp = last_frame_.map_points[i];
    if (!mp || mp->NumObservations() < 1) {
      auto temp = std::make_shared<MapPoint>(-1, last_frame_.UnprojectWorld(i), -1);
      temp->descriptor = last_frame_.descriptors[i];
      temp->observations.clear();
      last_frame_.map_points[i] = temp;
      last_frame_.outlier[i] = 0;
    }
    ++added;
    if (d > last_frame_.geometry->close_depth && added > options_.new_points_min) break;
  }
}

bool Tracker::TrackWithMotionModel(Frame& frame) {
  frame.cam_from_world = *velocity_ * last_frame_.cam_from_world;
  frame.has_pose = true;
  std::fill(frame.map_points.begin(), frame.map_points.end(), nullptr);
  int matches = matcher_.SearchByProjection(frame, last_frame_, options_.motion_radius_px);
  if (matches < options_.motion_min_matches) {
    std::fill(frame.map_points.begin(), frame.map_points.end(), nullptr);
    matches = matcher_.SearchByProjection(frame, last_frame_, 2 * options_.motion_radius_px);
  }
  if (matches < options_.motion_min_matches) return false;
  OptimizePose(frame, options_.optimizer);
  return frame.DiscardOutliers() >= options_.min_inliers;
}

bool Tracker::TrackReferenceKeyFrame(Frame& frame) {
  if (!reference_kf_ || reference_kf_->bad) {
    if (map_->keyframes().empty()) return false;
    reference_kf_ = map_->keyframes().rbegin()->second;
  }
  // Brute force against this one keyframe (its cost does not grow with the map; on
  // bonn_crowd_part, deterministic, ATE 0.0140 m this way vs 0.0158 m with the direct index
  // first), then, when that fails, through the vocabulary's direct index (other candidate pairs:
  // the ratio test within a node).
  const bool use_bow = vocabulary_ && !reference_kf_->bow_features.empty();
  for (int attempt = 1; attempt >= (use_bow ? 0 : 1); --attempt) {
    std::fill(frame.map_points.begin(), frame.map_points.end(), nullptr);
    int matches = 0;
    if (attempt == 0) {
      frame.ComputeBow(*vocabulary_);
      matches = matcher_.SearchByBow(*reference_kf_, frame, 0.7);
    } else {
      matches = matcher_.SearchByDescriptors(*reference_kf_, frame, 0.7);
    }
    if (matches < 15) continue;
    frame.cam_from_world =
        last_frame_.has_pose ? last_frame_.cam_from_world : reference_kf_->cam_from_world;
    frame.has_pose = true;
    OptimizePose(frame, options_.optimizer);
    if (frame.DiscardOutliers() >= options_.min_inliers) return true;
  }
  return false;
}

bool Tracker::Relocalize(Frame& frame) {
  const RelocalizationResult r =
      RelocalizeFrame(frame, *map_, database_.get(), vocabulary_.get(), matcher_, options_);
  if (!r.ok) return false;
  last_relocalization_frame_id_ = frame.id;
  reference_kf_ = r.keyframe;
  return true;
}

void Tracker::UpdateLocalMap(Frame& frame) {
  // Keyframes that see the frame's points, plus their best covisible neighbours.
  std::map<int64_t, int> counter;
  for (size_t i = 0; i < frame.size(); ++i) {
    const auto& mp = frame.map_points[i];
    if (!mp) continue;
    if (mp->bad) {
      frame.map_points[i] = nullptr;
      continue;
    }
    for (const auto& [kf_id, idx] : mp->observations) counter[kf_id]++;
  }
  local_keyframes_.clear();
  int best = 0;
  std::shared_ptr<KeyFrame> best_kf;
  for (const auto& [kf_id, n] : counter) {
    auto kf = map_->GetKeyFrame(kf_id);
    if (!kf || kf->bad) continue;
    if (n > best) {
      best = n;
      best_kf = kf;
    }
    local_keyframes_.push_back(kf);
    kf->track_reference_for_frame = frame.id;
  }
  if (localization_ && best_kf) {
    // Localization in a finished map: the keyframe that shares the most of the frame's matched
    // points and its best covisible keyframes only. Every keyframe that observes one matched point
    // (the mapping run's local map) mixes in points made at other times, with other drift, which
    // pull the pose (bonn_crowd_part, where every keyframe sees the same room: ATE 0.0157 m with
    // them, 0.0140 m without; BENCHMARKS.md, SLAM map files).
    for (const auto& kf : local_keyframes_) kf->track_reference_for_frame = -1;
    local_keyframes_ = {best_kf};
    best_kf->track_reference_for_frame = frame.id;
    for (int64_t id : best_kf->BestCovisibles(options_.local_keyframes_max)) {
      if (static_cast<int>(local_keyframes_.size()) >= options_.localization_local_keyframes) break;
      auto n = map_->GetKeyFrame(id);
      if (!n || n->bad) continue;
      n->track_reference_for_frame = frame.id;
      local_keyframes_.push_back(n);
    }
  }
  // Mapping: plus the best covisible neighbour of each (ORB-SLAM2's local map).
  const size_t direct = localization_ ? 0 : local_keyframes_.size();
  for (size_t k = 0;
       k < direct && static_cast<int>(local_keyframes_.size()) < options_.local_keyframes_max;
       ++k) {
    for (int64_t id : local_keyframes_[k]->BestCovisibles(10)) {
      auto n = map_->GetKeyFrame(id);
      if (!n || n->bad || n->track_reference_for_frame == frame.id) continue;
      n->track_reference_for_frame = frame.id;
      local_keyframes_.push_back(n);
      break;
    }
  }
  if (best_kf) reference_kf_ = best_kf;
  local_points_.clear();
  for (const auto& kf : local_keyframes_) {
    for (const auto& mp : kf->map_points) {
      if (!mp || mp->bad || mp->track_reference_for_frame == frame.id) continue;
      mp->track_reference_for_frame = frame.id;
      local_points_.push_back(mp);
    }
  }
}

bool Tracker::TrackLocalMap(Frame& frame) {
  UpdateLocalMap(frame);
  const CameraGeometry& g = *frame.geometry;
  for (const auto& mp : frame.map_points) {
    if (!mp) continue;
    // The map's statistics (visible / found, for point culling) are left alone in localization:
    // a localization run does not change the loaded map, not even its counters.
    if (!localization_) mp->visible_count++;
    mp->last_frame_seen = frame.id;
    mp->track_in_view = false;
  }
  const Eigen::Vector3d center = frame.CameraCenter();
  int to_match = 0;
  for (const auto& mp : local_points_) {
    if (mp->last_frame_seen == frame.id) continue;
    mp->track_in_view = false;
    const Eigen::Vector3d p = frame.cam_from_world * mp->position;
    if (p.z() <= 0) continue;
    const double inv_z = 1.0 / p.z();
    const double u = g.camera.fx * p.x() * inv_z + g.camera.cx;
    const double v = g.camera.fy * p.y() * inv_z + g.camera.cy;
    if (!g.InBounds(u, v)) continue;
    const Eigen::Vector3d po = mp->position - center;
    const double dist = po.norm();
    if (dist < 0.8 * mp->min_distance || dist > 1.2 * mp->max_distance) continue;
    const double view_cos = po.dot(mp->normal) / dist;
    if (view_cos < 0.5) continue;
    mp->track_in_view = true;
    mp->track_proj_x = u;
    mp->track_proj_y = v;
    mp->track_proj_xr = u - g.bf * inv_z;
    mp->track_view_cos = view_cos;
    mp->track_scale_level = mp->PredictScale(dist, g);
    if (!localization_) mp->visible_count++;
    ++to_match;
  }
  if (to_match > 0) {
    const double radius = frame.id < last_relocalization_frame_id_ + 2 ? 5.0 : 1.0;
    matcher_.SearchByProjection(frame, local_points_, radius);
  }
  OptimizePose(frame, options_.optimizer);
  int inliers = 0, static_inliers = 0;
  for (size_t i = 0; i < frame.size(); ++i) {
    const auto& mp = frame.map_points[i];
    if (!mp) continue;
    if (frame.outlier[i]) {
      frame.map_points[i] = nullptr;
      frame.outlier[i] = 0;
      continue;
    }
    if (!localization_) mp->found_count++;
    if (mp->NumObservations() > 0) {
      ++inliers;
      if (frame.in_dynamic_region.empty() || !frame.in_dynamic_region[i]) ++static_inliers;
    }
  }
  last_inliers_ = inliers;
  // The pose must rest on enough points outside the dynamic regions: features kept inside a
  // person's box (judged static by the geometry probability) can still move with the person,
  // and when a person fills the view the few background points left cannot hold the pose.
  const int needed =
      frame.id < last_relocalization_frame_id_ + options_.max_frames_between_keyframes
          ? options_.relocalized_min_inliers
          : options_.local_map_min_inliers;
  return static_inliers >= needed ||
         (static_inliers >= options_.local_map_min_inliers && last_relocalization_frame_id_ < 0);
}

bool Tracker::NeedNewKeyFrame(const Frame& frame) {
  const int64_t kfs = static_cast<int64_t>(map_->NumKeyFrames());
  if (frame.id < last_relocalization_frame_id_ + options_.max_frames_between_keyframes &&
      kfs > options_.max_frames_between_keyframes)
    return false;
  // ORB-SLAM2 counts an RGB-D observation twice; here each keyframe observation counts once.
  const int min_obs = kfs <= 2 ? 1 : 2;
  const int ref_matches = reference_kf_->NumTrackedPoints(min_obs);
  // Idle: no local BA pending. Both are decided by the frame sequence, not by the clock.
  const bool mapper_idle = local_mapper_.Idle();
  int tracked_close = 0, untracked_close = 0;
  const double close = frame.geometry->close_depth;
  for (size_t i = 0; i < frame.size(); ++i) {
    if (frame.depth[i] <= 0 || frame.depth[i] >= close) continue;
    // keyframe_counts_odometry_points = false (ORB-SLAM2's rule): map points only; the temporary
    // points made from the last frame's depth for the motion model (no keyframe observes them)
    // do not count as tracked. Counting them let the close features look tracked on a long
    // straight side of a generated loop while the real inliers fell from 591 to 37, so no
    // keyframe was made and tracking was lost (BENCHMARKS).
    if (frame.map_points[i] && !frame.outlier[i] &&
        (options_.keyframe_counts_odometry_points || frame.map_points[i]->NumObservations() > 0)) {
      ++tracked_close;
    } else if (frame.CanSeedPoint(i)) {
      // Only a point a keyframe would add to the map asks for one: a feature kept inside a
      // person's box seeds no point, and counting it made a keyframe on every frame while people
      // stood close (12 in a row on bonn_crowd_part, each a local BA: the run fell behind the
      // camera there).
      ++untracked_close;
    }
  }
  // The map-point floor (keyframe_min_map_inliers) joins the close-point rule: both say the map
  // no longer covers what the camera sees, whatever the odometry points hold up.
  const bool need_close = (tracked_close < options_.close_tracked_min &&
                           untracked_close > options_.close_untracked_min) ||
                          last_inliers_ < options_.keyframe_min_map_inliers;
  const double ratio = kfs < 2 ? 0.4 : options_.ref_ratio;
  const bool c2 = (last_inliers_ < ref_matches * ratio || need_close) && last_inliers_ > 15;
  const bool c1a = frame.id >= last_kf_frame_id_ + options_.max_frames_between_keyframes;
  const bool c1b = mapper_idle;
  const bool c1c = last_inliers_ < ref_matches * 0.25 || need_close;
  // A keyframe while a local BA is pending lands that BA first (LocalMapper::InsertKeyFrame).
  return (c1a || c1b || c1c) && c2;
}

std::shared_ptr<KeyFrame> Tracker::CreateKeyFrame(Frame& frame) {
  if (vocabulary_) frame.ComputeBow(*vocabulary_);
  auto kf = std::make_shared<KeyFrame>(map_->NextKeyFrameId(), frame);
  map_->AddKeyFrame(kf);
  if (database_) database_->Add(kf->id, kf->bow_vector);
  // Observations of the points tracked in this frame.
  for (size_t i = 0; i < kf->size(); ++i) {
    const auto& mp = kf->map_points[i];
    if (!mp) continue;
    if (mp->bad || mp->NumObservations() == 0 || mp->observations.count(kf->id)) {
      kf->map_points[i] = nullptr;  // temporary or culled point
      continue;
    }
    map_->AddObservation(mp, kf, static_cast<int>(i));
    map_->UpdateNormalAndDepth(*mp);
    map_->ComputeDistinctiveDescriptor(*mp);
  }
  // New points from depth: all close ones, at least new_points_min in total.
  std::vector<std::pair<float, size_t>> by_depth;
  for (size_t i = 0; i < kf->size(); ++i) {
    if (kf->CanSeedPoint(i)) by_depth.push_back({kf->depth[i], i});
  }
  std::sort(by_depth.begin(), by_depth.end());
  int created = 0, considered = 0;
  for (const auto& [d, i] : by_depth) {
    if (!kf->map_points[i]) {
      auto mp = std::make_shared<MapPoint>(map_->NextMapPointId(), kf->UnprojectWorld(i), kf->id);
      mp->ref_kf_id = kf->id;
      map_->AddObservation(mp, kf, static_cast<int>(i));
      map_->ComputeDistinctiveDescriptor(*mp);
      map_->UpdateNormalAndDepth(*mp);
      map_->AddMapPoint(mp);
      frame.map_points[i] = mp;
      ++created;
    }
    ++considered;
    if (d > frame.geometry->close_depth && considered > options_.new_points_min) break;
  }
  for (size_t i = 0; i < kf->size(); ++i) frame.map_points[i] = kf->map_points[i];
  map_->UpdateConnections(kf);
  reference_kf_ = kf;
  last_kf_ = kf;
  last_kf_frame_id_ = frame.id;
  return kf;
}

std::vector<StampedPose> Tracker::Trajectory() const {
  std::lock_guard<std::mutex> lock(map_->mutex());
  std::vector<StampedPose> out;
  for (const auto& r : records_) {
    if (!HasPose(r.state) || r.ref_kf_id < 0) continue;
    const Rigid3d cam_from_world = r.cam_from_ref * map_->ResolvedPose(r.ref_kf_id);
    out.push_back({r.stamp, cam_from_world.Inverse()});
  }
  return out;
}

std::vector<StampedPose> Tracker::KeyframeTrajectory(int64_t min_id) const {
  std::lock_guard<std::mutex> lock(map_->mutex());
  std::vector<StampedPose> out;
  for (auto it = map_->keyframes().lower_bound(min_id); it != map_->keyframes().end(); ++it) {
    const auto& kf = it->second;
    out.push_back({kf->stamp, kf->cam_from_world.Inverse()});
  }
  return out;
}

}  // namespace dygslam
