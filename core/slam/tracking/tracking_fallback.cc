// Tracker's second pose estimator: when feature tracking cannot hold a frame (too few
// static inliers, e.g. a person fills the view), its static depth is aligned densely against the
// last frame with a pose (else the newest keyframe), seeded by the motion model
// (StaticDepthOdometry). A feature pose held by few inliers (< fallback_check_below_inliers) is
// cross-checked the same way: when the dense pose explains the static depth clearly better
// (agreement higher by fallback_override_fraction_gain), it replaces the feature pose. Only a
// verified estimate becomes the frame's pose (state `fallback`); such frames never create
// keyframes or map points. Where the static view is narrow (a strip beside a person filling the
// view: few static pixels seen in both frames) or the plain alignment fails, the estimate
// constrained by the motion model decides (StaticDepthOdometry::EstimateWithPrior); so does the
// re-anchoring of a stretch. A feature pose held by few inliers right after a fallback frame
// continues the dense chain. A frame without a dense view, without a previous
// pose, or whose estimate fails the verification stays `lost`.
#include <cmath>

#include "core/base/log.h"
#include "core/slam/map/map.h"
#include "core/slam/tracking/tracking.h"

namespace dygslam {

void Tracker::RememberDenseKeyFrame(const std::shared_ptr<KeyFrame>& kf, const Frame& frame) {
  if (!kf || !frame.dense) return;
  dense_kf_ = kf;
  dense_kf_view_ = frame.dense;
}

void Tracker::PrepareDenseFallback(const PinholeCamera& camera) {
  if (options_.dense_fallback && !static_depth_odometry_)
    static_depth_odometry_ = std::make_unique<StaticDepthOdometry>(camera, options_.fallback);
}

std::optional<Tracker::DenseResult> Tracker::DenseEstimate(const Frame& frame,
                                                           const Rigid3d& predicted,
                                                           bool keyframe_only, bool with_prior) {
  if (!frame.dense) return std::nullopt;
  if (!static_depth_odometry_) {
    static_depth_odometry_ =
        std::make_unique<StaticDepthOdometry>(frame.geometry->camera, options_.fallback);
  }
  // References in order: the last frame (largest overlap), then the newest keyframe.
  struct Reference {
    const DenseView* view;
    Rigid3d cam_from_world;
    const char* name;
  };
  std::vector<Reference> references;
  if (last_frame_.dense && last_frame_.has_pose && !keyframe_only)
    references.push_back({last_frame_.dense.get(), last_frame_.cam_from_world, "last frame"});
  if (dense_kf_ && dense_kf_view_ && !dense_kf_->bad)
    references.push_back({dense_kf_view_.get(), dense_kf_->cam_from_world, "keyframe"});
  for (const Reference& ref : references) {
    const Rigid3d seed = predicted * ref.cam_from_world.Inverse();  // cur_from_ref
    const StaticDepthEstimate e = static_depth_odometry_->Estimate(*ref.view, *frame.dense, seed);
    LOG_DEBUG << "tracking: frame " << frame.id << " dense estimate against the " << ref.name
              << ": converged " << e.converged << ", verified " << e.verified << ", "
              << e.agreement.inliers << "/" << e.agreement.correspondences << " agree ("
              << e.agreement.samples << " samples), rmse " << e.agreement.rmse << " m, "
              << e.time_ms << " ms";
    // A narrow static view (a strip beside a person filling the view) verifies estimates that
    // slid along the directions it leaves free: the constrained estimate decides there.
    if (e.verified && with_prior && NarrowView(e.agreement)) break;
    if (e.verified)
      return DenseResult{e.cur_from_ref * ref.cam_from_world, ref.cam_from_world, ref.view,
                         e.agreement};
  }
  if (with_prior && !references.empty() && references.front().view == last_frame_.dense.get()) {
    const Reference& ref = references.front();
    const Rigid3d prior = held_velocity_ ? *held_velocity_ * last_frame_.cam_from_world : predicted;
    const Rigid3d seed = prior * ref.cam_from_world.Inverse();
    const StaticDepthEstimate e =
        static_depth_odometry_->EstimateWithPrior(*ref.view, *frame.dense, seed);
    LOG_DEBUG << "tracking: frame " << frame.id
              << " dense estimate with the motion prior against the last frame: verified "
              << e.verified << ", " << e.agreement.inliers << "/" << e.agreement.correspondences
              << " agree (" << e.agreement.samples << " samples), rmse " << e.agreement.rmse
              << " m, " << e.time_ms << " ms";
    if (e.verified)
      return DenseResult{e.cur_from_ref * ref.cam_from_world, ref.cam_from_world, ref.view,
                         e.agreement, true};
  }
  return std::nullopt;
}

bool Tracker::NarrowView(const DepthAgreement& agreement) const {
  // The static pixels seen in both frames count: a person entering or leaving the view leaves a
  // strip of them even where one of the two frames shows more.
  return agreement.correspondences < options_.fallback_narrow_view_samples;
}

bool Tracker::DenseOverridesFeaturePose(Frame& frame, const std::optional<Rigid3d>& predicted) {
  if (!predicted || !frame.dense || last_inliers_ >= options_.fallback_check_below_inliers)
    return false;
  // Against the last frame when features held its pose, else against the newest keyframe (its
  // pose rests on the map): comparing with a dense (fallback) last frame would favour continuing
  // the dense chain over features that have found the map again.
  const std::optional<DenseResult> dense = DenseEstimate(frame, *predicted, LastWasFallback());
  if (!dense) return false;
  const DepthAgreement& dense_agreement = dense->agreement;
  // The feature pose measured the same way, against the same reference.
  const DepthAgreement feature_agreement = static_depth_odometry_->Agreement(
      *dense->ref_view, *frame.dense, frame.cam_from_world * dense->ref_from_world.Inverse());
  const Rigid3d diff = dense->cam_from_world * frame.cam_from_world.Inverse();
  LOG_DEBUG << "tracking: frame " << frame.id << " (" << last_inliers_
            << " feature inliers) feature pose agreement " << feature_agreement.inlier_fraction()
            << " rmse " << feature_agreement.rmse << ", dense " << dense_agreement.inlier_fraction()
            << " rmse " << dense_agreement.rmse << "; poses differ by " << diff.translation.norm()
            << " m, " << RotationAngle(diff.rotation) * 180 / M_PI << " deg";
  // The dense pose wins when more of the static depth agrees with it, or when as much agrees but
  // with a clearly larger residual under the feature pose.
  const double gain = dense_agreement.inlier_fraction() - feature_agreement.inlier_fraction();
  const bool clearly_better =
      gain >= options_.fallback_override_fraction_gain ||
      (gain > 0 &&
       feature_agreement.rmse > options_.fallback_override_rmse_ratio * dense_agreement.rmse);
  if (!clearly_better) return false;
  frame.cam_from_world = dense->cam_from_world;
  return AcceptDensePose(frame);
}

bool Tracker::TrackWithStaticDepth(Frame& frame, const std::optional<Rigid3d>& predicted,
                                   bool narrow_only) {
  if (!predicted || !frame.dense || !reference_kf_) return false;
  const std::optional<DenseResult> dense = DenseEstimate(frame, *predicted, false, true);
  if (!dense || (narrow_only && !dense->constrained)) return false;
  frame.cam_from_world = dense->cam_from_world;
  return AcceptDensePose(frame);
}

bool Tracker::AcceptDensePose(Frame& frame) {
  frame.has_pose = true;
  // Keep only the feature associations that agree with the dense pose (they seed the motion model
  // of the next frame); nothing is written to the map.
  const CameraGeometry& g = *frame.geometry;
  for (size_t i = 0; i < frame.size(); ++i) {
    auto& mp = frame.map_points[i];
    if (!mp) continue;
    const Eigen::Vector3d p = frame.cam_from_world * mp->position;
    bool keep = !frame.outlier[i] && !mp->bad && p.z() > 0;
    if (keep) {
      const double du = g.camera.fx * p.x() / p.z() + g.camera.cx - frame.undistorted[i].pt.x;
      const double dv = g.camera.fy * p.y() / p.z() + g.camera.cy - frame.undistorted[i].pt.y;
      const int level = frame.undistorted[i].octave;
      keep = (du * du + dv * dv) * g.inv_sigma2[level] < 5.991;
    }
    if (!keep) {
      mp = nullptr;
      frame.outlier[i] = 0;
    }
  }
  return true;
}

namespace {
// The pose between `a` (s = 0) and `b` (s = 1): camera centres interpolated linearly, rotations
// by slerp.
Rigid3d InterpolatePose(const Rigid3d& a_cam_from_world, const Rigid3d& b_cam_from_world,
                        double s) {
  const Rigid3d a = a_cam_from_world.Inverse(), b = b_cam_from_world.Inverse();
  const Rigid3d world_from_cam(a.rotation.slerp(s, b.rotation),
                               (1 - s) * a.translation + s * b.translation);
  return world_from_cam.Inverse();
}
}  // namespace

bool Tracker::SmoothFallbackStretch(const Frame& frame, const std::optional<Rigid3d>& predicted) {
  if (!predicted || !frame.dense || !last_frame_.dense || !last_frame_.has_pose) return false;
  if (!static_depth_odometry_) return false;
  // Where the last fallback frame should have been, given this frame's feature pose.
  const Rigid3d seed = *predicted * last_frame_.cam_from_world.Inverse();  // cur_from_last
  StaticDepthEstimate e = static_depth_odometry_->Estimate(*last_frame_.dense, *frame.dense, seed);
  if (!e.verified || NarrowView(e.agreement))
    e = static_depth_odometry_->EstimateWithPrior(*last_frame_.dense, *frame.dense, seed);
  if (!e.verified) {
    LOG_DEBUG << "tracking: frame " << frame.id
              << " fallback stretch not re-anchored (dense estimate not verified)";
    return false;
  }
  const Rigid3d last_corrected = e.cur_from_ref.Inverse() * frame.cam_from_world;
  // world-side correction: last_corrected = last * correction (relative poses kept).
  const Rigid3d correction = last_frame_.cam_from_world.Inverse() * last_corrected;
  const Rigid3d jump = last_corrected * last_frame_.cam_from_world.Inverse();
  if (jump.translation.norm() > options_.fallback_smoothing_max_translation ||
      RotationAngle(jump.rotation) * 180.0 / M_PI > options_.fallback_smoothing_max_rotation_deg) {
    LOG_DEBUG << "tracking: frame " << frame.id << " fallback stretch not re-anchored (correction "
              << jump.translation.norm() << " m)";
    return false;
  }
  // The stretch: the fallback records at the end, then the feature frames just before them whose
  // pose rested on few inliers (the drift of the stretch starts there).
  size_t begin = records_.size();
  while (begin > 0 && records_[begin - 1].state == TrackingState::kFallback) --begin;
  const size_t fallback_begin = begin;
  while (begin > 0 && records_[begin - 1].state == TrackingState::kOk &&
         records_[begin - 1].ref_kf_id >= 0 &&
         records_[begin - 1].num_inliers < options_.fallback_smoothing_weak_inliers)
    --begin;
  // The correction is spread evenly over the stretch (weak feature frames and dense frames
  // alike): weighting the dense frames less was measured no better on bonn_crowd_part.
  std::vector<double> cumulative;
  double total = 0;
  for (size_t k = begin; k < records_.size(); ++k) {
    total += 1.0;
    cumulative.push_back(total);
  }
  for (size_t k = begin; k < records_.size(); ++k) {
    TrajectoryRecord& r = records_[k];
    if (r.ref_kf_id < 0) continue;
    const Rigid3d ref_from_world = map_->ResolvedPose(r.ref_kf_id);
    const Rigid3d cam_from_world = r.cam_from_ref * ref_from_world;
    const double s = total > 0 ? cumulative[k - begin] / total : 1.0;
    const Rigid3d corrected = InterpolatePose(cam_from_world, cam_from_world * correction, s);
    r.cam_from_ref = corrected * ref_from_world.Inverse();
  }
  last_frame_.cam_from_world = last_corrected;
  LOG_DEBUG << "tracking: frame " << frame.id << " re-anchored " << records_.size() - fallback_begin
            << " fallback frames and " << fallback_begin - begin << " weakly held ones by "
            << jump.translation.norm() << " m, " << RotationAngle(jump.rotation) * 180 / M_PI
            << " deg";
  return true;
}

}  // namespace dygslam
