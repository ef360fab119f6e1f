#include "core/slam/loop_closing/loop_verification.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <map>
#include <set>
#include <utility>

#include "core/base/log.h"
#include "core/slam/loop_closing/loop_detection.h"
#include "core/slam/optimize/cost_functions.h"
#include "core/slam/optimize/pose_solver.h"

namespace dygslam {

namespace {

// Rigid transform dst_from_src minimising the squared distances (Horn / Umeyama, no scale).
Rigid3d AlignPoints(const std::vector<Eigen::Vector3d>& src,
                    const std::vector<Eigen::Vector3d>& dst) {
  Eigen::Matrix3Xd a(3, src.size()), b(3, dst.size());
  for (size_t i = 0; i < src.size(); ++i) {
    a.col(i) = src[i];
    b.col(i) = dst[i];
  }
  const Eigen::Matrix4d m = Eigen::umeyama(a, b, false);
  return Rigid3d(Eigen::Matrix3d(m.topLeftCorner<3, 3>()),
                 Eigen::Vector3d(m.topRightCorner<3, 1>()));
}

bool Reprojects(const KeyFrame& kf, int idx, const Eigen::Vector3d& p_cam, double threshold2) {
  if (p_cam.z() <= 0) return false;
  const auto& g = *kf.geometry;
  const double u = g.camera.fx * p_cam.x() / p_cam.z() + g.camera.cx;
  const double v = g.camera.fy * p_cam.y() / p_cam.z() + g.camera.cy;
  const cv::KeyPoint& kp = kf.undistorted[idx];
  const double e2 = (u - kp.pt.x) * (u - kp.pt.x) + (v - kp.pt.y) * (v - kp.pt.y);
  return e2 < threshold2 * g.sigma2[kp.octave];
}

// A map point as the loop checks see it: copied under the map lock (LoopVerifier::Snapshot).
struct PointCopy {
  std::shared_ptr<MapPoint> point;  // handed to the correction (under the lock again); not read
                                    // without the lock: the fields below are the copy
  Eigen::Vector3d position, normal;
  Descriptor descriptor;
  double min_distance = 0, max_distance = 0;
};

// MapPoint::PredictScale on a copy.
int PredictLevel(const PointCopy& p, double distance, const CameraGeometry& g) {
  const double ratio = p.max_distance / distance;
  const int level = static_cast<int>(std::ceil(std::log(ratio) / g.log_scale_factor));
  return std::clamp(level, 0, g.num_levels - 1);
}

// The best unmatched feature of kf for the copied point `mp` seen from `cam_from_world` (centre
// `center`), or -1.
int BestFeatureFor(const KeyFrame& kf, const Rigid3d& cam_from_world, const Eigen::Vector3d& center,
                   const PointCopy& mp, double radius_px, int max_distance,
                   const std::vector<int>& matches) {
  const auto& g = *kf.geometry;
  const Eigen::Vector3d p = cam_from_world * mp.position;
  if (p.z() <= 0) return -1;
  const double u = g.camera.fx * p.x() / p.z() + g.camera.cx;
  const double v = g.camera.fy * p.y() / p.z() + g.camera.cy;
  if (!g.InBounds(u, v)) return -1;
  const Eigen::Vector3d po = mp.position - center;
  const double dist = po.norm();
  if (dist < 0.8 * mp.min_distance || dist > 1.2 * mp.max_distance) return -1;
  if (po.dot(mp.normal) < 0.5 * dist) return -1;
  const int level = PredictLevel(mp, dist, g);
  int best = 256, best_idx = -1;
  for (int c : kf.grid.Query(kf.undistorted, u, v, radius_px * g.scales[level],
                             std::max(0, level - 1), level + 1)) {
    if (matches[c] >= 0) continue;
    const int d = HammingDistance(mp.descriptor, kf.descriptors[c]);
    if (d < best) {
      best = d;
      best_idx = c;
    }
  }
  return best_idx >= 0 && best <= max_distance ? best_idx : -1;
}

// Matches the copied points `candidates` (indices into `points`, not yet in `matches`) into kf
// seen from `cam_from_world`; matches[i] = index of the point matched to feature i (-1: none).
// Returns the added count.
int SearchByProjection(const KeyFrame& kf, const Rigid3d& cam_from_world,
                       const std::vector<PointCopy>& points, const std::vector<int>& candidates,
                       double radius_px, int max_distance, std::vector<int>* matches) {
  const Eigen::Vector3d center = cam_from_world.Inverse().translation;
  std::set<int> already;
  for (int m : *matches)
    if (m >= 0) already.insert(m);
  int added = 0;
  for (int index : candidates) {
    if (already.count(index)) continue;
    const int feature = BestFeatureFor(kf, cam_from_world, center, points[index], radius_px,
                                       max_distance, *matches);
    if (feature < 0) continue;
    (*matches)[feature] = index;
    already.insert(index);
    ++added;
  }
  return added;
}

// Marks the matches of `matches` that `cam_from_world` reprojects beyond the chi2 thresholds as
// outliers; returns the inliers.
int FlagPoseOutliers(const KeyFrame& kf, const OptimizerOptions& optimizer,
                     const ProjectionModel& model, const std::vector<PointCopy>& points,
                     const std::vector<int>& matches, const Rigid3d& cam_from_world,
                     std::vector<uint8_t>* outlier) {
  const auto& g = *kf.geometry;
  int inliers = 0;
  for (size_t i = 0; i < matches.size(); ++i) {
    const int m = matches[i];
    if (m < 0) continue;
    const cv::KeyPoint& kp = kf.undistorted[i];
    const Eigen::Vector3d p = cam_from_world * points[m].position;
    bool bad = p.z() <= 0;
    if (!bad) {
      const double u = model.fx * p.x() / p.z() + model.cx;
      const double v = model.fy * p.y() / p.z() + model.cy;
      double chi2 = (u - kp.pt.x) * (u - kp.pt.x) + (v - kp.pt.y) * (v - kp.pt.y);
      const bool stereo = kf.u_right[i] >= 0;
      if (stereo) {
        const double ur = u - model.bf / p.z();
        chi2 += (ur - kf.u_right[i]) * (ur - kf.u_right[i]);
      }
      chi2 *= g.inv_sigma2[kp.octave];
      bad = chi2 > (stereo ? optimizer.chi2_stereo : optimizer.chi2_mono);
    }
    (*outlier)[i] = bad ? 1 : 0;
    inliers += bad ? 0 : 1;
  }
  return inliers;
}

// Refines the current keyframe's corrected pose against the loop-side points matched to its
// features (tracking's pose-only solver: reprojection with the depth's virtual right coordinate,
// Huber-robust, then outlier rounds as in tracking); outlier matches are removed. Returns the
// inliers.
int RefineLoopPose(const KeyFrame& kf, const OptimizerOptions& optimizer,
                   const std::vector<PointCopy>& points, std::vector<int>* matches,
                   Rigid3d* cam_from_world) {
  const auto& g = *kf.geometry;
  const ProjectionModel model{g.camera.fx, g.camera.fy, g.camera.cx, g.camera.cy, g.bf};
  std::vector<PoseObservation> observations;
  std::vector<size_t> feature_of;  // observation -> feature
  for (size_t i = 0; i < matches->size(); ++i) {
    const int m = (*matches)[i];
    if (m < 0) continue;
    const cv::KeyPoint& kp = kf.undistorted[i];
    PoseObservation o;
    o.point = points[m].position;
    o.stereo = kf.u_right[i] >= 0;
    o.measurement = Eigen::Vector3d(kp.pt.x, kp.pt.y, o.stereo ? kf.u_right[i] : 0.0);
    o.information = g.inv_sigma2[kp.octave];
    observations.push_back(o);
    feature_of.push_back(i);
  }
  PoseSolverOptions solver;
  solver.max_iterations = optimizer.pose_iterations;
  const double delta_mono = std::sqrt(optimizer.chi2_mono),
               delta_stereo = std::sqrt(optimizer.chi2_stereo);
  std::vector<uint8_t> outlier(matches->size(), 0), active(observations.size(), 1);
  Rigid3d pose = *cam_from_world;
  int inliers = 0;
  for (int round = 0; round < optimizer.pose_rounds; ++round) {
    int added = 0;
    for (size_t k = 0; k < observations.size(); ++k) {
      active[k] = outlier[feature_of[k]] ? 0 : 1;
      added += active[k];
    }
    if (added < 3) return 0;
    SolvePose(observations, active.data(), model, delta_mono, delta_stereo, solver, &pose);
    inliers = FlagPoseOutliers(kf, optimizer, model, points, *matches, pose, &outlier);
    if (inliers < 10) return inliers;
  }
  if (!pose.AllFinite()) return 0;
  *cam_from_world = pose;
  for (size_t i = 0; i < matches->size(); ++i)
    if (outlier[i]) (*matches)[i] = -1;
  return inliers;
}

// A BoW correspondence between the current keyframe and a candidate, both with a map point,
// in each camera's frame.
struct Pair {
  int idx1, idx2;
  Eigen::Vector3d p1, p2;
  int loop_point;  // index into the snapshot's points
};

// The SE3 that best explains `pairs`: RANSAC on 3-point solutions, then least squares on the
// inliers, re-scored, twice.
struct RansacTransform {
  int inliers = 0;
  Rigid3d t12;  // current camera from candidate camera
  std::vector<uint8_t> flags;
};

RansacTransform EstimateLoopTransform(const KeyFrame& kf, const KeyFrame& c,
                                      const std::vector<Pair>& pairs, double th2, int iterations,
                                      uint64_t* rng) {
  auto next = [rng]() {
    *rng = *rng * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<uint32_t>(*rng >> 33);
  };
  auto count_inliers = [&](const Rigid3d& t12, std::vector<uint8_t>* flags) {
    const Rigid3d t21 = t12.Inverse();
    int n = 0;
    flags->assign(pairs.size(), 0);
    for (size_t k = 0; k < pairs.size(); ++k) {
      if (Reprojects(kf, pairs[k].idx1, t12 * pairs[k].p2, th2) &&
          Reprojects(c, pairs[k].idx2, t21 * pairs[k].p1, th2)) {
        (*flags)[k] = 1;
        ++n;
      }
    }
    return n;
  };
  auto align = [&](const std::vector<size_t>& chosen) {
    std::vector<Eigen::Vector3d> src, dst;
    for (size_t k : chosen) {
      src.push_back(pairs[k].p2);
      dst.push_back(pairs[k].p1);
    }
    return AlignPoints(src, dst);
  };
  RansacTransform best;
  std::vector<uint8_t> flags;
  for (int it = 0; it < iterations; ++it) {
    std::vector<size_t> s(3);
    s[0] = next() % pairs.size();
    do s[1] = next() % pairs.size();
    while (s[1] == s[0]);
    do s[2] = next() % pairs.size();
    while (s[2] == s[0] || s[2] == s[1]);
    const Rigid3d t12 = align(s);
    if (!t12.AllFinite()) continue;
    const int n = count_inliers(t12, &flags);
    if (n > best.inliers) best = {n, t12, flags};
  }
  for (int round = 0; round < 2 && best.inliers >= 3; ++round) {
    std::vector<size_t> chosen;
    for (size_t k = 0; k < pairs.size(); ++k)
      if (best.flags[k]) chosen.push_back(k);
    const Rigid3d refined = align(chosen);
    if (!refined.AllFinite()) break;
    const int n = count_inliers(refined, &flags);
    if (n < best.inliers) break;
    best = {n, refined, flags};
  }
  return best;
}

void LogRejection(const KeyFrame& kf, const KeyFrame& c, const LoopVerification& v) {
  LOG_DEBUG << "loop closing: keyframe " << kf.id << " (frame " << kf.frame_id << ") vs " << c.id
            << " (frame " << c.frame_id << "): rejected (" << v.verdict << "): " << v.inliers
            << " / " << v.bow_pairs << " inliers, " << v.projected << " matches, correction "
            << v.correction_m << " m / " << v.correction_deg << " deg, budget " << v.allowed_m
            << " m / " << v.allowed_deg << " deg over " << v.path_m << " m";
}

}  // namespace

// What the geometric checks read of the map state, copied under the map lock: keyframe poses,
// which feature has which map point, and the points' positions, descriptors and viewing data.
// The keyframes' immutable features (keypoints, descriptors, grid, BoW) are read from the
// keyframes themselves, which needs no lock.
struct LoopVerifier::Snapshot {
  struct View {
    std::shared_ptr<KeyFrame> kf;
    Rigid3d cam_from_world;
    std::vector<int> points;         // per feature: index into `points` (-1: none or bad)
    std::vector<uint8_t> usable;     // per feature: points[i] >= 0
    std::vector<int> observation;    // per feature: the point's observation index in kf (-1: none)
    double path_m = 0;               // keyframe path from kf to the current keyframe
    std::vector<int> neighbourhood;  // points of kf and its covisible keyframes (on demand)
    bool neighbourhood_copied = false;
  };
  int64_t epoch = -1;
  View current;
  std::vector<View> candidates;
  std::vector<PointCopy> points;
  std::map<const MapPoint*, int> index;
  double locked_ms = 0;  // time spent holding the map lock for the copies

  // The BoW matches `matched` (candidate feature per current feature, -1: none) whose features
  // both have a map point, in each camera's frame.
  std::vector<Pair> Correspondences(const View& candidate, const std::vector<int>& matched) const {
    std::vector<Pair> pairs;
    for (size_t i = 0; i < matched.size(); ++i) {
      const int i2 = matched[i];
      if (i2 < 0) continue;
      const int lp = candidate.points[i2], mp = current.points[i];
      if (lp < 0 || mp < 0 || candidate.observation[i2] < 0) continue;
      pairs.push_back({static_cast<int>(i), candidate.observation[i2],
                       current.cam_from_world * points[mp].position,
                       candidate.cam_from_world * points[lp].position, lp});
    }
    return pairs;
  }
  // The loop accepted with `candidate`: the current keyframe at `cam_from_world`, its features
  // matched to the loop-side points `kept` (index per feature, -1: none).
  LoopMatch Accepted(const View& candidate, const Rigid3d& cam_from_world,
                     const std::vector<int>& kept, int inliers, const LoopVerification& v) const {
    LoopMatch loop;
    loop.loop_kf = candidate.kf;
    loop.cam_from_world = cam_from_world;
    loop.matches.assign(kept.size(), nullptr);
    for (size_t i = 0; i < kept.size(); ++i)
      if (kept[i] >= 0) loop.matches[i] = points[kept[i]].point;
    for (int index : candidate.neighbourhood) loop.loop_points.push_back(points[index].point);
    loop.inliers = inliers;
    loop.projected = v.projected;
    loop.correction_m = v.correction_m;
    loop.correction_deg = v.correction_deg;
    loop.epoch = epoch;
    return loop;
  }
  // The caller holds Map::mutex().
  int Add(const std::shared_ptr<MapPoint>& mp) {
    auto [it, inserted] = index.emplace(mp.get(), static_cast<int>(points.size()));
    if (inserted) {
      points.push_back(
          {mp, mp->position, mp->normal, mp->descriptor, mp->min_distance, mp->max_distance});
    }
    return it->second;
  }
  void Copy(const std::shared_ptr<KeyFrame>& kf, View* view) {
    view->kf = kf;
    view->cam_from_world = kf->cam_from_world;
    view->points.assign(kf->size(), -1);
    view->usable.assign(kf->size(), 0);
    view->observation.assign(kf->size(), -1);
    for (size_t i = 0; i < kf->size(); ++i) {
      const auto& mp = kf->map_points[i];
      if (!mp || mp->bad) continue;
      view->points[i] = Add(mp);
      view->usable[i] = 1;
      auto obs = mp->observations.find(kf->id);
      if (obs != mp->observations.end()) view->observation[i] = obs->second;
    }
  }
};

LoopVerifier::LoopVerifier(std::shared_ptr<Map> map, const LoopClosingOptions& options,
                           const OptimizerOptions& optimizer, const MatcherOptions& matcher)
    : map_(std::move(map)), options_(options), optimizer_(optimizer), matcher_(matcher) {}

bool LoopVerifier::TakeSnapshot(const std::shared_ptr<KeyFrame>& kf,
                                const std::vector<std::shared_ptr<KeyFrame>>& candidates,
                                Snapshot* snapshot) const {
  std::lock_guard<std::mutex> lock(map_->mutex());
  const auto start = std::chrono::steady_clock::now();
  if (kf->bad) return false;
  snapshot->epoch = map_->CorrectionEpoch();
  snapshot->Copy(kf, &snapshot->current);
  for (const auto& c : candidates) {
    if (c->bad) continue;
    snapshot->candidates.emplace_back();
    snapshot->Copy(c, &snapshot->candidates.back());
    snapshot->candidates.back().path_m = KeyFramePathLength(*map_, c->id, kf->id);
  }
  snapshot->locked_ms +=
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return true;
}

void LoopVerifier::CopyNeighbourhood(size_t candidate, Snapshot* snapshot) const {
  Snapshot::View& view = snapshot->candidates[candidate];
  if (view.neighbourhood_copied) return;
  std::lock_guard<std::mutex> lock(map_->mutex());
  const auto start = std::chrono::steady_clock::now();
  std::vector<std::shared_ptr<KeyFrame>> neighbourhood = {view.kf};
  for (int64_t id : view.kf->ordered_connections) {
    auto n = map_->GetKeyFrame(id);
    if (n && !n->bad) neighbourhood.push_back(n);
  }
  std::set<int64_t> seen;
  for (const auto& n : neighbourhood) {
    for (const auto& mp : n->map_points) {
      if (mp && !mp->bad && seen.insert(mp->id).second)
        view.neighbourhood.push_back(snapshot->Add(mp));
    }
  }
  view.neighbourhood_copied = true;
  snapshot->locked_ms +=
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

std::optional<LoopMatch> LoopVerifier::Verify(
    const std::shared_ptr<KeyFrame>& kf, const std::vector<std::shared_ptr<KeyFrame>>& candidates,
    LoopCheckRecord* record) const {
  // No map lock in the checks: everything mutable comes from the snapshot (CopyNeighbourhood
  // locks briefly for a candidate that reaches the guided search).
  Snapshot snapshot;
  std::optional<LoopMatch> found;
  if (TakeSnapshot(kf, candidates, &snapshot)) {
    uint64_t rng = static_cast<uint64_t>(kf->id) * 2654435761ULL + 1;
    for (size_t ci = 0; ci < snapshot.candidates.size() && !found; ++ci)
      found = VerifyCandidate(ci, &snapshot, &rng, record);
  }
  record->locked_ms += snapshot.locked_ms;
  return found;
}

std::optional<LoopMatch> LoopVerifier::VerifyCandidate(size_t ci, Snapshot* snapshot, uint64_t* rng,
                                                       LoopCheckRecord* record) const {
  const Snapshot::View& current = snapshot->current;
  const Snapshot::View& candidate = snapshot->candidates[ci];
  const KeyFrame &kf = *current.kf, &c = *candidate.kf;
  const auto& points = snapshot->points;
  LoopVerification v;
  v.frame_id = kf.frame_id;
  v.loop_frame_id = c.frame_id;
  v.path_m = candidate.path_m;
  auto reject = [&](const char* verdict, int LoopCheckRecord::*counter) {
    v.verdict = verdict;
    LogRejection(kf, c, v);
    record->*counter += 1;
    record->verifications.push_back(v);
    return std::nullopt;
  };
  std::vector<int> matched(kf.size(), -1);  // candidate feature per current feature
  const auto bow = matcher_.SearchByBow(kf, current.usable, c, candidate.usable, 0.75);
  v.bow_pairs = static_cast<int>(bow.size());
  if (v.bow_pairs < options_.min_bow_matches)
    return reject("BoW matches", &LoopCheckRecord::rejected_bow);
  for (const auto& [i1, i2] : bow) matched[i1] = i2;
  const std::vector<Pair> pairs = snapshot->Correspondences(candidate, matched);
  v.bow_pairs = static_cast<int>(pairs.size());
  if (v.bow_pairs < options_.min_bow_matches)
    return reject("BoW matches", &LoopCheckRecord::rejected_bow);
  const double th2 = options_.ransac_threshold_px * options_.ransac_threshold_px;
  const RansacTransform t =
      EstimateLoopTransform(kf, c, pairs, th2, options_.ransac_iterations, rng);
  LOG_DEBUG << "loop closing: keyframe " << kf.id << " vs " << c.id << ": " << pairs.size()
            << " BoW matches, " << t.inliers << " RANSAC inliers";
  v.inliers = t.inliers;
  v.allowed_m = options_.max_correction_m + options_.max_drift_per_meter * v.path_m;
  v.allowed_deg = options_.max_correction_deg + options_.max_drift_deg_per_meter * v.path_m;
  // Correction: where the loop transform puts the camera against where odometry has it.
  const Eigen::Vector3d kf_center = current.cam_from_world.Inverse().translation;
  auto implausible = [&](const Rigid3d& pose) {
    const Rigid3d delta = pose * current.cam_from_world.Inverse();
    v.correction_m = (kf_center - pose.Inverse().translation).norm();
    v.correction_deg = Eigen::AngleAxisd(delta.rotation).angle() * 180.0 / M_PI;
    return v.correction_m > v.allowed_m || v.correction_deg > v.allowed_deg;
  };
  const Rigid3d corrected_pose = t.t12 * candidate.cam_from_world;
  const bool implausible_before = implausible(corrected_pose);
  if (t.inliers < options_.min_ransac_inliers)
    return reject("inliers", &LoopCheckRecord::rejected_inliers);
  if (t.inliers < options_.min_inlier_ratio * static_cast<double>(pairs.size()))
    return reject("inlier ratio", &LoopCheckRecord::rejected_ratio);
  if (implausible_before)
    return reject("implausible correction", &LoopCheckRecord::rejected_implausible);
  // Guided search: the candidate's neighbourhood seen from the corrected pose.
  std::vector<int> kept(kf.size(), -1);  // loop-side point per current feature
  for (size_t k = 0; k < pairs.size(); ++k)
    if (t.flags[k]) kept[pairs[k].idx1] = pairs[k].loop_point;
  CopyNeighbourhood(ci, snapshot);
  SearchByProjection(kf, corrected_pose, points, candidate.neighbourhood, 10.0,
                     matcher_.options().th_low, &kept);
  // The transform from a few 3D-3D inliers carries their depth noise: refine the pose on every
  // match by reprojection, keep the inliers, and check the correction again.
  Rigid3d refined_pose = corrected_pose;
  v.projected = RefineLoopPose(kf, optimizer_, points, &kept, &refined_pose);
  if (v.projected < options_.min_projection_matches)
    return reject("guided matches", &LoopCheckRecord::rejected_projection);
  if (implausible(refined_pose))
    return reject("implausible correction", &LoopCheckRecord::rejected_implausible);
  v.verdict = "accepted";
  record->verifications.push_back(v);
  return snapshot->Accepted(candidate, refined_pose, kept, t.inliers, v);
}

}  // namespace dygslam
