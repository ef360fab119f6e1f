#include "core/slam/loop_closing.h"

#include <ceres/ceres.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>
#include <string>

#include "core/base/log.h"
#include "core/base/memory.h"
#include "core/base/thread_setup.h"
#include "core/slam/cost_functions.h"
#include "core/slam/pose_graph.h"

namespace dygslam {

struct LoopCloser::Loop {
  std::shared_ptr<KeyFrame> loop_kf;
  Rigid3d cam_from_world;                              // corrected pose of the current keyframe
  std::vector<std::shared_ptr<MapPoint>> matches;      // per feature of the current keyframe
  std::vector<std::shared_ptr<MapPoint>> loop_points;  // the loop keyframe's neighbourhood
  int inliers = 0, projected = 0;
  double correction_m = 0, correction_deg = 0;  // how far the loop moves the current keyframe
  int64_t epoch = -1;  // Map::CorrectionEpoch() of the map state the checks saw
};

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

// A map point as the loop checks see it: copied under the map lock (LoopCloser::Snapshot).
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

// Matches the copied points `candidates` (indices into `points`, not yet in `matches`) into kf
// seen from `cam_from_world`; matches[i] = index of the point matched to feature i (-1: none).
// Returns the added count.
int SearchByProjection(const KeyFrame& kf, const Rigid3d& cam_from_world,
                       const std::vector<PointCopy>& points, const std::vector<int>& candidates,
                       double radius_px, int max_distance, std::vector<int>* matches) {
  const auto& g = *kf.geometry;
  const Eigen::Vector3d center = cam_from_world.Inverse().translation;
  std::set<int> already;
  for (int m : *matches)
    if (m >= 0) already.insert(m);
  int added = 0;
  for (int index : candidates) {
    if (already.count(index)) continue;
    const PointCopy& mp = points[index];
    const Eigen::Vector3d p = cam_from_world * mp.position;
    if (p.z() <= 0) continue;
    const double u = g.camera.fx * p.x() / p.z() + g.camera.cx;
    const double v = g.camera.fy * p.y() / p.z() + g.camera.cy;
    if (!g.InBounds(u, v)) continue;
    const Eigen::Vector3d po = mp.position - center;
    const double dist = po.norm();
    if (dist < 0.8 * mp.min_distance || dist > 1.2 * mp.max_distance) continue;
    if (po.dot(mp.normal) < 0.5 * dist) continue;
    const int level = PredictLevel(mp, dist, g);
    int best = 256, best_idx = -1;
    for (int c : kf.grid.Query(kf.undistorted, u, v, radius_px * g.scales[level],
                               std::max(0, level - 1), level + 1)) {
      if ((*matches)[c] >= 0) continue;
      const int d = HammingDistance(mp.descriptor, kf.descriptors[c]);
      if (d < best) {
        best = d;
        best_idx = c;
      }
    }
    if (best_idx >= 0 && best <= max_distance) {
      (*matches)[best_idx] = index;
      already.insert(index);
      ++added;
    }
  }
  return added;
}

// Refines the current keyframe's corrected pose against the loop-side points matched to its
// features (pose-only, reprojection with the depth's virtual right coordinate, Huber then
// outlier rounds as in tracking); outlier matches are removed. Returns the inliers.
int RefineLoopPose(const KeyFrame& kf, const OptimizerOptions& optimizer,
                   const std::vector<PointCopy>& points, std::vector<int>* matches,
                   Rigid3d* cam_from_world) {
  const auto& g = *kf.geometry;
  const ProjectionModel model{g.camera.fx, g.camera.fy, g.camera.cx, g.camera.cy, g.bf};
  std::vector<uint8_t> outlier(matches->size(), 0);
  double pose[7];
  PoseToParameters(*cam_from_world, pose);
  const double delta_mono = std::sqrt(optimizer.chi2_mono),
               delta_stereo = std::sqrt(optimizer.chi2_stereo);
  int inliers = 0;
  for (int round = 0; round < optimizer.pose_rounds; ++round) {
    ceres::Problem::Options problem_options;
    problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem problem(problem_options);
    PoseManifold manifold;
    problem.AddParameterBlock(pose, 7, &manifold);
    int added = 0;
    for (size_t i = 0; i < matches->size(); ++i) {
      const int m = (*matches)[i];
      if (m < 0 || outlier[i]) continue;
      const cv::KeyPoint& kp = kf.undistorted[i];
      const double sqrt_info = std::sqrt(g.inv_sigma2[kp.octave]);
      const bool stereo = kf.u_right[i] >= 0;
      ceres::CostFunction* cost = stereo ? static_cast<ceres::CostFunction*>(new StereoPoseCost(
                                               Eigen::Vector3d(kp.pt.x, kp.pt.y, kf.u_right[i]),
                                               points[m].position, sqrt_info, model))
                                         : new MonoPoseCost(Eigen::Vector2d(kp.pt.x, kp.pt.y),
                                                            points[m].position, sqrt_info, model);
      problem.AddResidualBlock(cost, new ceres::HuberLoss(stereo ? delta_stereo : delta_mono),
                               pose);
      ++added;
    }
    if (added < 3) return 0;
    ceres::Solver::Options solver_options;
    solver_options.linear_solver_type = ceres::DENSE_QR;
    solver_options.max_num_iterations = optimizer.pose_iterations;
    solver_options.num_threads = 1;
    solver_options.logging_type = ceres::SILENT;
    ceres::Solver::Summary summary;
    ceres::Solve(solver_options, &problem, &summary);
    const Rigid3d estimate = PoseFromParameters(pose);
    inliers = 0;
    for (size_t i = 0; i < matches->size(); ++i) {
      const int m = (*matches)[i];
      if (m < 0) continue;
      const cv::KeyPoint& kp = kf.undistorted[i];
      const Eigen::Vector3d p = estimate * points[m].position;
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
      outlier[i] = bad ? 1 : 0;
      inliers += bad ? 0 : 1;
    }
    if (inliers < 10) return inliers;
  }
  if (!PoseFromParameters(pose).AllFinite()) return 0;
  *cam_from_world = PoseFromParameters(pose);
  for (size_t i = 0; i < matches->size(); ++i)
    if (outlier[i]) (*matches)[i] = -1;
  return inliers;
}

// Length of the path of the keyframe centres from each keyframe id in [from, to] to keyframe
// `to` (ids in creation order), culled keyframes included at their resolved pose: skipping them
// would cut the corners of the path (on the there-and-back sequence, 1.39 m instead of ~1.9 m
// at the return). Ids that were never made (a loaded map may have gaps) are absent. The caller
// holds Map::mutex().
std::map<int64_t, double> KeyFramePathLengths(const Map& map, int64_t from, int64_t to) {
  std::vector<std::pair<int64_t, Eigen::Vector3d>> centers;
  for (int64_t id = std::max<int64_t>(from, 0); id <= to; ++id) {
    if (const auto active = map.keyframes().find(id); active != map.keyframes().end())
      centers.emplace_back(id, active->second->CameraCenter());
    else if (map.IsCulled(id))
      centers.emplace_back(id, map.ResolvedPose(id).Inverse().translation);
  }
  std::map<int64_t, double> lengths;
  double length = 0;
  for (size_t k = centers.size(); k-- > 0;) {
    if (k + 1 < centers.size()) length += (centers[k + 1].second - centers[k].second).norm();
    lengths[centers[k].first] = length;
  }
  return lengths;
}

}  // namespace

double KeyFramePathLength(const Map& map, int64_t from, int64_t to) {
  const auto lengths = KeyFramePathLengths(map, from, to);
  const auto it = lengths.find(from);
  return it == lengths.end() ? 0.0 : it->second;
}

// What the geometric checks read of the map state, copied under the map lock: keyframe poses,
// which feature has which map point, and the points' positions, descriptors and viewing data.
// The keyframes' immutable features (keypoints, descriptors, grid, BoW) are read from the
// keyframes themselves, which needs no lock.
struct LoopCloser::Snapshot {
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

std::string LoopRejectionSummary(const LoopClosingStats& stats) {
  const LoopVerification* strongest = nullptr;
  for (const LoopVerification& v : stats.verifications) {
    if (std::string(v.verdict) == "accepted") continue;
    if (!strongest || v.inliers > strongest->inliers ||
        (v.inliers == strongest->inliers && v.bow_pairs > strongest->bow_pairs))
      strongest = &v;
  }
  if (!strongest) return "";
  char line[512];
  std::snprintf(
      line, sizeof(line),
      "loop rejections: %d BoW matches, %d inliers, %d inlier ratio, %d guided matches, "
      "%d implausible correction; strongest: frame %lld vs frame %lld: %d / %d inliers, "
      "%d matches, correction %.3f m / %.2f deg (budget %.3f m / %.2f deg over %.2f m): "
      "%s",
      stats.rejected_bow, stats.rejected_inliers, stats.rejected_ratio, stats.rejected_projection,
      stats.rejected_implausible, static_cast<long long>(strongest->frame_id),
      static_cast<long long>(strongest->loop_frame_id), strongest->inliers, strongest->bow_pairs,
      strongest->projected, strongest->correction_m, strongest->correction_deg,
      strongest->allowed_m, strongest->allowed_deg, strongest->path_m, strongest->verdict);
  return line;
}

LoopCloser::LoopCloser(std::shared_ptr<Map> map, std::shared_ptr<KeyFrameDatabase> database,
                       const LoopClosingOptions& options, const OptimizerOptions& optimizer,
                       const MatcherOptions& matcher, bool threaded, bool threaded_checks)
    : map_(std::move(map)),
      database_(std::move(database)),
      options_(options),
      optimizer_(optimizer),
      matcher_(matcher),
      threaded_(threaded),
      queue_([this](std::shared_ptr<KeyFrame>& kf) { Process(kf); }, threaded && threaded_checks,
             /*capacity=*/0, "loop closing") {
  options_.Check();
}

LoopCloser::~LoopCloser() { Finish(); }

void LoopCloser::SetCorrectionCallback(CorrectionCallback callback) {
  std::lock_guard<std::mutex> lock(callback_mutex_);
  callback_ = std::move(callback);
}

LoopClosingStats LoopCloser::stats() const {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  return stats_;
}

void LoopCloser::InsertKeyFrame(std::shared_ptr<KeyFrame> kf) {
  queue_.Push(std::move(kf));
  queue_.Drain();  // unthreaded: processed now
}

void LoopCloser::Finish() {
  queue_.Finish();
  std::lock_guard<std::mutex> lock(global_ba_mutex_);
  if (global_ba_thread_.joinable()) global_ba_thread_.join();
}

void LoopCloser::Report(const std::vector<int64_t>& moved) {
  CorrectionCallback callback;
  {
    std::lock_guard<std::mutex> lock(callback_mutex_);
    callback = callback_;
  }
  if (callback && !moved.empty()) callback(moved);
}

void LoopCloser::Process(const std::shared_ptr<KeyFrame>& kf) {
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    stats_.keyframes_checked++;
  }
  if (!options_.enabled) return;
  const auto detect_start = std::chrono::steady_clock::now();
  const auto candidates = DetectLoop(kf);
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    stats_.detect_ms_total +=
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - detect_start)
            .count();
  }
  if (candidates.empty()) return;
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    stats_.candidates_detected += static_cast<int>(candidates.size());
  }
  Loop loop;
  const auto check_start = std::chrono::steady_clock::now();
  Snapshot snapshot;
  const bool found = TakeSnapshot(kf, candidates, &snapshot) && ComputeTransform(&snapshot, &loop);
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    stats_.check_ms_total +=
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - check_start)
            .count();
    stats_.check_locked_ms_total += snapshot.locked_ms;
    if (!found) stats_.loops_rejected++;
  }
  if (!found) return;
  const auto start = std::chrono::steady_clock::now();
  bool fused_only = false;
  const bool applied = CorrectLoop(kf, loop, &fused_only);
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    stats_.correction_ms_total += ms;
  }
  // Nothing moved when the loop was only fused: nothing for a global BA to spread.
  if (!applied || fused_only || !options_.global_bundle_adjustment) return;
  StartGlobalBundleAdjustment(kf->id);
}

std::vector<std::shared_ptr<KeyFrame>> LoopCloser::DetectLoop(const std::shared_ptr<KeyFrame>& kf) {
  // Under the map lock: what the index query's filter needs (the keyframes' BoW vectors are
  // immutable). The query itself, the costly part, runs without the lock.
  std::vector<std::shared_ptr<KeyFrame>> covisibles;
  std::set<int64_t> active, connected;
  std::map<int64_t, double> revisit_path;  // keyframe path from an old covisible keyframe to kf
  {
    std::lock_guard<std::mutex> lock(map_->mutex());
    if (kf->bad || kf->bow_vector.empty()) return {};
    if (last_loop_kf_id_ >= 0 && kf->id < last_loop_kf_id_ + options_.min_keyframe_gap) return {};
    if (static_cast<int>(map_->NumKeyFrames()) <= options_.min_keyframe_gap) return {};
    for (int64_t id : kf->ordered_connections) {
      auto n = map_->GetKeyFrame(id);
      if (n && !n->bad && !n->bow_vector.empty()) covisibles.push_back(n);
    }
    for (const auto& [id, k] : map_->keyframes()) active.insert(id);
    int64_t oldest = kf->id;
    for (const auto& [id, w] : kf->connection_weights) {
      connected.insert(id);
      if (options_.revisit_min_path_m > 0 && id <= kf->id - options_.min_keyframe_gap)
        oldest = std::min(oldest, id);
    }
    if (oldest < kf->id) {
      const auto lengths = KeyFramePathLengths(*map_, oldest, kf->id);
      for (int64_t id : connected) {
        const auto it = lengths.find(id);
        if (id <= kf->id - options_.min_keyframe_gap && it != lengths.end())
          revisit_path[id] = it->second;
      }
    }
  }
  // The keyframe's worst covisible neighbour sets the bar.
  double min_score = 1.0;
  for (const auto& n : covisibles)
    min_score = std::min(min_score, Vocabulary::Score(kf->bow_vector, n->bow_vector));
  if (covisibles.empty()) min_score = 0;
  const auto found = QueryLoopCandidates(
      *database_, *kf, min_score,
      [&](int64_t id) {
        if (active.count(id) == 0) return true;                    // culled
        if (id > kf->id - options_.min_keyframe_gap) return true;  // recent
        if (connected.count(id) == 0) return false;
        // Covisible: ORB-SLAM2 excludes these, as covisibility normally means the local window
        // (already joined by local BA, nothing to correct). An old keyframe that became
        // covisible again after a long way round is the place revisited, tracked without losing
        // the map (there and back): it stays a candidate, so the revisit is closed as a loop.
        const auto path = revisit_path.find(id);
        return options_.revisit_min_path_m <= 0 || path == revisit_path.end() ||
               path->second < options_.revisit_min_path_m;
      },
      options_.place);
  std::lock_guard<std::mutex> lock(map_->mutex());
  const auto candidates = GroupPlaceCandidates(*map_, found, options_.place);
  if (GetLogLevel() <= LogLevel::kDebug) {
    std::ostringstream line;
    line << "loop detection: keyframe " << kf->id << " (frame " << kf->frame_id << "), bar "
         << min_score << ", " << found.size() << " found, " << candidates.size()
         << " after grouping; old covisible:";
    for (const auto& [id, path] : revisit_path) line << " " << id << " (" << path << " m)";
    line << "; grouped:";
    for (const auto& c : candidates) line << " " << c->id << " (frame " << c->frame_id << ")";
    LOG_DEBUG << line.str();
  }
  if (candidates.empty()) {
    consistent_groups_.clear();
    return {};
  }
  // Consistency: a candidate group that overlaps a group of the previous keyframe inherits its
  // count + 1; enough consecutive overlaps make the candidate a loop.
  std::vector<ConsistentGroup> current;
  std::vector<uint8_t> used(consistent_groups_.size(), 0);
  std::vector<std::shared_ptr<KeyFrame>> enough;
  for (const auto& c : candidates) {
    std::set<int64_t> group = {c->id};
    for (const auto& [id, w] : c->connection_weights) group.insert(id);
    bool consistent_any = false, added = false;
    for (size_t g = 0; g < consistent_groups_.size(); ++g) {
      bool overlap = false;
      for (int64_t id : group) {
        if (consistent_groups_[g].keyframes.count(id)) {
          overlap = true;
          break;
        }
      }
      if (!overlap) continue;
      consistent_any = true;
      const int consistency = consistent_groups_[g].consistency + 1;
      if (!used[g]) {
        current.push_back({group, consistency});
        used[g] = 1;
      }
      if (consistency >= options_.consistency && !added) {
        enough.push_back(c);
        added = true;
      }
    }
    if (!consistent_any) current.push_back({group, 0});
  }
  consistent_groups_ = std::move(current);
  return enough;
}

bool LoopCloser::TakeSnapshot(const std::shared_ptr<KeyFrame>& kf,
                              const std::vector<std::shared_ptr<KeyFrame>>& candidates,
                              Snapshot* snapshot) {
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

void LoopCloser::CopyNeighbourhood(size_t candidate, Snapshot* snapshot) {
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

bool LoopCloser::ComputeTransform(Snapshot* snapshot, Loop* loop) {
  // No map lock here: everything mutable comes from the snapshot (CopyNeighbourhood locks
  // briefly for the one candidate that reaches the guided search).
  const Snapshot::View& current = snapshot->current;
  const KeyFrame& kf = *current.kf;
  const auto& points = snapshot->points;
  const Eigen::Vector3d kf_center = current.cam_from_world.Inverse().translation;
  const double th2 = options_.ransac_threshold_px * options_.ransac_threshold_px;
  uint64_t rng = static_cast<uint64_t>(kf.id) * 2654435761ULL + 1;
  auto next = [&rng]() {
    rng = rng * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<uint32_t>(rng >> 33);
  };
  for (size_t ci = 0; ci < snapshot->candidates.size(); ++ci) {
    const Snapshot::View& candidate = snapshot->candidates[ci];
    const KeyFrame& c = *candidate.kf;
    // (current feature, candidate feature), both with a map point.
    const auto bow = matcher_.SearchByBow(kf, current.usable, c, candidate.usable, 0.75);
    // Too few correspondences to try: recorded too (the first check a candidate can fail).
    auto too_few_matches = [&](size_t found) {
      LoopVerification v;
      v.frame_id = kf.frame_id;
      v.loop_frame_id = c.frame_id;
      v.bow_pairs = static_cast<int>(found);
      v.path_m = candidate.path_m;
      v.verdict = "BoW matches";
      LOG_DEBUG << "loop closing: keyframe " << kf.id << " (frame " << kf.frame_id << ") vs "
                << c.id << " (frame " << c.frame_id << "): rejected (BoW matches): " << found
                << " of " << options_.min_bow_matches;
      std::lock_guard<std::mutex> stats_lock(stats_mutex_);
      stats_.rejected_bow++;
      stats_.verifications.push_back(v);
    };
    if (static_cast<int>(bow.size()) < options_.min_bow_matches) {
      too_few_matches(bow.size());
      continue;
    }
    std::vector<int> matched(kf.size(), -1);  // candidate feature per current feature
    for (const auto& [i1, i2] : bow) matched[i1] = i2;
    // Correspondences in each camera's frame.
    struct Pair {
      int idx1, idx2;
      Eigen::Vector3d p1, p2;
      int loop_point;  // index into points
    };
    std::vector<Pair> pairs;
    for (size_t i = 0; i < kf.size(); ++i) {
      const int i2 = matched[i];
      if (i2 < 0) continue;
      const int lp = candidate.points[i2], mp = current.points[i];
      if (lp < 0 || mp < 0 || candidate.observation[i2] < 0) continue;
      pairs.push_back({static_cast<int>(i), candidate.observation[i2],
                       current.cam_from_world * points[mp].position,
                       candidate.cam_from_world * points[lp].position, lp});
    }
    if (static_cast<int>(pairs.size()) < options_.min_bow_matches) {
      too_few_matches(pairs.size());
      continue;
    }
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
    int best = 0;
    Rigid3d best_t12;
    std::vector<uint8_t> flags, best_flags;
    for (int it = 0; it < options_.ransac_iterations; ++it) {
      std::array<size_t, 3> s;
      s[0] = next() % pairs.size();
      do s[1] = next() % pairs.size();
      while (s[1] == s[0]);
      do s[2] = next() % pairs.size();
      while (s[2] == s[0] || s[2] == s[1]);
      std::vector<Eigen::Vector3d> src, dst;
      for (size_t k : s) {
        src.push_back(pairs[k].p2);
        dst.push_back(pairs[k].p1);
      }
      const Rigid3d t12 = AlignPoints(src, dst);
      if (!t12.AllFinite()) continue;
      const int n = count_inliers(t12, &flags);
      if (n > best) {
        best = n;
        best_t12 = t12;
        best_flags = flags;
      }
    }
    LOG_DEBUG << "loop closing: keyframe " << kf.id << " vs " << c.id << ": " << pairs.size()
              << " BoW matches, " << best << " RANSAC inliers";
    LoopVerification v;
    v.frame_id = kf.frame_id;
    v.loop_frame_id = c.frame_id;
    v.bow_pairs = static_cast<int>(pairs.size());
    // Refinement: least squares on the inliers, re-scored, twice.
    for (int round = 0; round < 2 && best >= 3; ++round) {
      std::vector<Eigen::Vector3d> src, dst;
      for (size_t k = 0; k < pairs.size(); ++k) {
        if (!best_flags[k]) continue;
        src.push_back(pairs[k].p2);
        dst.push_back(pairs[k].p1);
      }
      const Rigid3d refined = AlignPoints(src, dst);
      if (!refined.AllFinite()) break;
      const int n = count_inliers(refined, &flags);
      if (n < best) break;
      best = n;
      best_t12 = refined;
      best_flags = flags;
    }
    v.inliers = best;
    const Rigid3d corrected_pose = best_t12 * candidate.cam_from_world;
    v.path_m = candidate.path_m;
    v.allowed_m = options_.max_correction_m + options_.max_drift_per_meter * v.path_m;
    v.allowed_deg = options_.max_correction_deg + options_.max_drift_deg_per_meter * v.path_m;
    // Correction: where the loop transform puts the camera against where odometry has it.
    auto measure = [&](const Rigid3d& pose) {
      const Rigid3d delta = pose * current.cam_from_world.Inverse();
      v.correction_m = (kf_center - pose.Inverse().translation).norm();
      v.correction_deg = Eigen::AngleAxisd(delta.rotation).angle() * 180.0 / M_PI;
    };
    measure(corrected_pose);
    auto reject = [&](const char* verdict, int LoopClosingStats::*counter) {
      v.verdict = verdict;
      LOG_DEBUG << "loop closing: keyframe " << kf.id << " (frame " << kf.frame_id << ") vs "
                << c.id << " (frame " << c.frame_id << "): rejected (" << verdict
                << "): " << v.inliers << " / " << v.bow_pairs << " inliers, " << v.projected
                << " matches, correction " << v.correction_m << " m / " << v.correction_deg
                << " deg, budget " << v.allowed_m << " m / " << v.allowed_deg << " deg over "
                << v.path_m << " m";
      std::lock_guard<std::mutex> stats_lock(stats_mutex_);
      stats_.*counter += 1;
      stats_.verifications.push_back(v);
    };
    if (best < options_.min_ransac_inliers) {
      reject("inliers", &LoopClosingStats::rejected_inliers);
      continue;
    }
    if (best < options_.min_inlier_ratio * static_cast<double>(pairs.size())) {
      reject("inlier ratio", &LoopClosingStats::rejected_ratio);
      continue;
    }
    if (v.correction_m > v.allowed_m || v.correction_deg > v.allowed_deg) {
      reject("implausible correction", &LoopClosingStats::rejected_implausible);
      continue;
    }
    // Guided search: the candidate's neighbourhood seen from the corrected pose.
    std::vector<int> kept(kf.size(), -1);  // loop-side point per current feature
    for (size_t k = 0; k < pairs.size(); ++k)
      if (best_flags[k]) kept[pairs[k].idx1] = pairs[k].loop_point;
    CopyNeighbourhood(ci, snapshot);
    const std::vector<int>& loop_points = candidate.neighbourhood;
    SearchByProjection(kf, corrected_pose, points, loop_points, 10.0, matcher_.options().th_low,
                       &kept);
    // The transform from a few 3D-3D inliers carries their depth noise: refine the pose on every
    // match by reprojection, keep the inliers, and check the correction again.
    Rigid3d refined_pose = corrected_pose;
    const int total = RefineLoopPose(kf, optimizer_, points, &kept, &refined_pose);
    v.projected = total;
    if (total < options_.min_projection_matches) {
      reject("guided matches", &LoopClosingStats::rejected_projection);
      continue;
    }
    measure(refined_pose);
    if (v.correction_m > v.allowed_m || v.correction_deg > v.allowed_deg) {
      reject("implausible correction", &LoopClosingStats::rejected_implausible);
      continue;
    }
    v.verdict = "accepted";
    {
      std::lock_guard<std::mutex> stats_lock(stats_mutex_);
      stats_.verifications.push_back(v);
    }
    loop->loop_kf = candidate.kf;
    loop->cam_from_world = refined_pose;
    loop->matches.assign(kf.size(), nullptr);
    for (size_t i = 0; i < kept.size(); ++i)
      if (kept[i] >= 0) loop->matches[i] = points[kept[i]].point;
    loop->loop_points.clear();
    for (int index : loop_points) loop->loop_points.push_back(points[index].point);
    loop->inliers = best;
    loop->projected = total;
    loop->correction_m = v.correction_m;
    loop->correction_deg = v.correction_deg;
    loop->epoch = snapshot->epoch;
    return true;
  }
  return false;
}

namespace {

// `edges` with every id replaced by the active keyframe that stands for it; edges whose ends fall
// on one keyframe (or on none) dropped, each pair once. Map lock held.
std::vector<std::pair<int64_t, int64_t>> ResolveLoopEdges(
    const Map& map, const std::vector<std::pair<int64_t, int64_t>>& edges) {
  std::set<std::pair<int64_t, int64_t>> kept;
  std::vector<std::pair<int64_t, int64_t>> resolved;
  for (const auto& [a, b] : edges) {
    const int64_t i = map.ActiveKeyFrameId(a), j = map.ActiveKeyFrameId(b);
    if (i < 0 || j < 0 || i == j) continue;
    if (kept.insert(std::minmax(i, j)).second) resolved.push_back({i, j});
  }
  return resolved;
}

}  // namespace

void LoopCloser::CompactLoopEdges() { loop_edges_ = ResolveLoopEdges(*map_, loop_edges_); }

std::vector<std::pair<int64_t, int64_t>> LoopCloser::LoopEdges() const {
  std::lock_guard<std::mutex> lock(map_->mutex());
  return ResolveLoopEdges(*map_, loop_edges_);
}

void LoopCloser::AddLoopEdges(const std::vector<std::pair<int64_t, int64_t>>& links) {
  for (const auto& l : links) loop_edges_.push_back(l);
  CompactLoopEdges();
  std::lock_guard<std::mutex> lock(stats_mutex_);
  stats_.loop_edges = static_cast<int>(loop_edges_.size());
}

bool LoopCloser::CorrectLoop(const std::shared_ptr<KeyFrame>& kf, const Loop& loop,
                             bool* fused_only) {
  std::vector<int64_t> moved;
  int fused = 0;
  double shift = 0;
  bool fuse_only = false;
  {
    std::lock_guard<std::mutex> lock(map_->mutex());
    // The checks ran without the lock: the map may have changed meanwhile. A culled keyframe or
    // a global correction (a global BA written back moves every pose the transform was computed
    // from) makes the loop stale: it is dropped (the revisit is seen again by later keyframes).
    if (kf->bad || loop.loop_kf->bad || map_->CorrectionEpoch() != loop.epoch) {
      LOG_INFO << "loop dropped: keyframe " << kf->id << " with keyframe " << loop.loop_kf->id
               << (kf->bad || loop.loop_kf->bad ? " (a keyframe was culled)"
                                                : " (the map was corrected during the checks)");
      std::lock_guard<std::mutex> stats_lock(stats_mutex_);
      stats_.loops_dropped++;
      return false;
    }
    // A correction below the pose graph threshold moves nothing: the map was not lost, the
    // duplicated points are fused and the sides linked at the poses they have.
    fuse_only = loop.correction_m < options_.pose_graph_min_correction_m &&
                loop.correction_deg < options_.pose_graph_min_correction_deg;
    // Local BA in flight must not write back pre-loop poses (nothing moves when fusing only).
    if (!fuse_only) map_->BumpCorrectionEpoch();
    // 1. Move the current keyframe's neighbourhood (and the points it sees) by the loop transform.
    // A revisit (loop keyframe covisible with the current one) must not move the loop side.
    std::set<int64_t> loop_side = {loop.loop_kf->id};
    for (const auto& [id, w] : loop.loop_kf->connection_weights) loop_side.insert(id);
    std::vector<std::shared_ptr<KeyFrame>> group = {kf};
    for (int64_t id : kf->ordered_connections) {
      if (loop_side.count(id)) continue;
      auto n = map_->GetKeyFrame(id);
      if (n && !n->bad) group.push_back(n);
    }
    std::map<int64_t, Rigid3d> uncorrected, corrected;
    const Rigid3d kf_from_world = kf->cam_from_world;
    for (const auto& g : group) {
      uncorrected[g->id] = g->cam_from_world;
      corrected[g->id] = (g->cam_from_world * kf_from_world.Inverse()) * loop.cam_from_world;
    }
    shift = (kf->CameraCenter() - loop.cam_from_world.Inverse().translation).norm();
    if (!fuse_only) {
      std::set<int64_t> moved_points;
      std::vector<std::shared_ptr<MapPoint>> touched;
      for (const auto& g : group) {
        const Rigid3d world_from_new = corrected[g->id].Inverse();
        for (const auto& mp : g->map_points) {
          if (!mp || mp->bad || !moved_points.insert(mp->id).second) continue;
          mp->position = world_from_new * (uncorrected[g->id] * mp->position);
          touched.push_back(mp);
        }
      }
      for (const auto& g : group) g->cam_from_world = corrected[g->id];
      for (const auto& mp : touched) map_->UpdateNormalAndDepth(*mp);
    }
    // 2. Fuse: the loop's matched points replace the current keyframe's duplicates, then the
    // loop neighbourhood's points are fused into every corrected keyframe.
    for (size_t i = 0; i < loop.matches.size(); ++i) {
      const auto& lp = loop.matches[i];
      if (!lp || lp->bad) continue;
      const auto current = kf->map_points[i];
      if (current && !current->bad) {
        if (current != lp) {
          map_->Replace(current, lp);
          ++fused;
        }
      } else if (lp->observations.count(kf->id) == 0) {
        map_->AddObservation(lp, kf, static_cast<int>(i));
        map_->ComputeDistinctiveDescriptor(*lp);
        ++fused;
      }
    }
    for (const auto& g : group)
      fused += matcher_.Fuse(*map_, g, loop.loop_points, options_.fusion_radius_px);
    // 3. Covisibility after fusion; links that appeared between the two sides are loop edges.
    std::set<int64_t> group_ids;
    for (const auto& g : group) group_ids.insert(g->id);
    std::map<int64_t, std::set<int64_t>> before;
    for (const auto& g : group)
      for (const auto& [id, w] : g->connection_weights) before[g->id].insert(id);
    for (const auto& g : group) map_->UpdateConnections(g);
    std::vector<std::pair<int64_t, int64_t>> new_links;
    for (const auto& g : group) {
      for (const auto& [id, w] : g->connection_weights) {
        if (group_ids.count(id) || before[g->id].count(id)) continue;
        new_links.push_back({g->id, id});
      }
    }
    new_links.push_back({kf->id, loop.loop_kf->id});
    // The loop keyframes are not protected from culling (ORB-SLAM2 keeps every one for good, so a
    // robot returning to the same places grows its map by two keyframes per loop without bound).
    // A loop edge outlives its keyframes instead: it moves to the active keyframe that took over
    // a culled one's place (CompactLoopEdges), and repeated returns to the same pair of places
    // leave one edge.
    if (fuse_only) {
      // Kept for the pose graph of a later, larger loop; measured there from the poses it sees.
      AddLoopEdges(new_links);
      last_loop_kf_id_ = kf->id;
      consistent_groups_.clear();
    } else {
      // 4. Essential graph: spanning tree, strong covisibility, old loop edges from the poses
      // before this correction; the new loop links from the corrected ones.
      std::map<int64_t, Rigid3d> poses, measure;
      for (const auto& [id, k] : map_->keyframes()) {
        poses[id] = k->cam_from_world;
        auto u = uncorrected.find(id);
        measure[id] = u != uncorrected.end() ? u->second : k->cam_from_world;
      }
      std::vector<PoseGraphEdge> edges;
      auto relative = [](const std::map<int64_t, Rigid3d>& p, int64_t i, int64_t j) {
        return p.at(i) * p.at(j).Inverse();
      };
      std::set<std::pair<int64_t, int64_t>> added;
      auto add = [&](int64_t i, int64_t j, const std::map<int64_t, Rigid3d>& from) {
        if (!poses.count(i) || !poses.count(j) || i == j) return;
        const auto key = std::minmax(i, j);
        if (!added.insert(key).second) return;
        edges.push_back({i, j, relative(from, i, j), 1.0});
      };
      for (const auto& [a, b] : new_links) add(a, b, poses);
      CompactLoopEdges();
      for (const auto& [a, b] : loop_edges_) add(a, b, measure);
      for (const auto& [id, k] : map_->keyframes()) {
        if (k->parent_id >= 0) add(id, k->parent_id, measure);
        for (const auto& [other, w] : k->connection_weights)
          if (w >= options_.essential_min_weight) add(id, other, measure);
      }
      AddLoopEdges(new_links);
      std::set<int64_t> fixed = {loop.loop_kf->id, map_->keyframes().begin()->first};
      const std::map<int64_t, Rigid3d> before_graph = poses;
      OptimizePoseGraph(&poses, edges, fixed, options_.pose_graph_iterations);
      // 5. Keyframes take the optimised poses; points follow their reference keyframe.
      for (const auto& [id, k] : map_->keyframes()) {
        k->cam_from_world = poses[id];
        moved.push_back(id);
      }
      for (const auto& [pid, mp] : map_->map_points()) {
        if (mp->bad) continue;
        int64_t ref = mp->ref_kf_id;
        if (!poses.count(ref)) {
          ref = -1;
          for (const auto& [kid, idx] : mp->observations)
            if (poses.count(kid)) {
              ref = kid;
              break;
            }
        }
        if (ref < 0) continue;
        mp->position = poses[ref].Inverse() * (before_graph.at(ref) * mp->position);
        map_->UpdateNormalAndDepth(*mp);
      }
      map_->BumpCorrectionEpoch();
      last_loop_kf_id_ = kf->id;
      consistent_groups_.clear();
    }
  }
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    stats_.loops_closed++;
    stats_.points_fused += fused;
    if (fuse_only) stats_.pose_graph_skipped++;
    stats_.loops.push_back({kf->id, loop.loop_kf->id});
    stats_.loop_frames.push_back({kf->frame_id, loop.loop_kf->frame_id});
  }
  LOG_INFO << "loop closed: keyframe " << kf->id << " (frame " << kf->frame_id << ") with keyframe "
           << loop.loop_kf->id << " (frame " << loop.loop_kf->frame_id << "): " << loop.inliers
           << " RANSAC inliers, " << loop.projected << " matches, correction " << shift << " m, "
           << fused << " points fused"
           << (fuse_only ? " (below LoopClosing.pose_graph_min_correction_m / _deg: no keyframe "
                           "moved, no pose graph)"
                         : "");
  Report(moved);
  *fused_only = fuse_only;
  return true;
}

// A global BA allocates the whole map's problem at once (tens of MB, in its thread's malloc arena)
// and frees it at the end: ReleaseFreedMemory hands the pages back (the 30-minute soak saw RSS step
// up 18 MB around its one global BA while the heap in use stayed flat).
void LoopCloser::StartGlobalBundleAdjustment(int64_t loop_kf_id) {
  const int64_t epoch = map_->CorrectionEpoch();
  std::lock_guard<std::mutex> lock(global_ba_mutex_);
  if (global_ba_thread_.joinable()) {
    global_ba_abort_ = true;
    global_ba_thread_.join();
  }
  global_ba_abort_ = false;
  if (!threaded_) {
    RunGlobalBundleAdjustment(epoch);
    ReleaseFreedMemory();
    return;
  }
  global_ba_thread_ = std::thread([this, epoch] {
    SetCurrentThreadName("global BA");
    RunGlobalBundleAdjustment(epoch);
    ReleaseFreedMemory();
  });
}

void LoopCloser::RunGlobalBundleAdjustment(int64_t epoch) {
  struct Observation {
    int64_t kf_id, point_id;
    Eigen::Vector3d measurement;
    double sqrt_info;
    bool stereo;
  };
  std::map<int64_t, std::array<double, 7>> poses;
  std::map<int64_t, Rigid3d> before;
  std::map<int64_t, Eigen::Vector3d> points;
  std::vector<Observation> observations;
  ProjectionModel model{};
  int64_t first_kf = -1;
  const auto start = std::chrono::steady_clock::now();
  {
    std::lock_guard<std::mutex> lock(map_->mutex());
    if (map_->CorrectionEpoch() != epoch || map_->keyframes().empty()) return;
    first_kf = map_->keyframes().begin()->first;
    const auto& g = *map_->keyframes().begin()->second->geometry;
    model = {g.camera.fx, g.camera.fy, g.camera.cx, g.camera.cy, g.bf};
    for (const auto& [id, k] : map_->keyframes()) {
      PoseToParameters(k->cam_from_world, poses[id].data());
      before[id] = k->cam_from_world;
    }
    for (const auto& [pid, mp] : map_->map_points()) {
      if (mp->bad || mp->NumObservations() < 2) continue;
      points[pid] = mp->position;
      for (const auto& [kid, idx] : mp->observations) {
        auto k = map_->GetKeyFrame(kid);
        if (!k) continue;
        const cv::KeyPoint& kp = k->undistorted[idx];
        const bool stereo = k->u_right[idx] >= 0;
        observations.push_back({kid, pid,
                                Eigen::Vector3d(kp.pt.x, kp.pt.y, stereo ? k->u_right[idx] : 0.0),
                                std::sqrt(k->geometry->inv_sigma2[kp.octave]), stereo});
      }
    }
  }
  if (observations.empty()) return;
  auto steady_s = [](std::chrono::steady_clock::time_point t) {
    return std::chrono::duration<double>(t.time_since_epoch()).count();
  };
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    stats_.global_ba_running = true;
    stats_.global_ba_windows_s.push_back({steady_s(start), steady_s(start)});
  }
  // Closes this BA's window in the statistics on every way out.
  struct WindowCloser {
    LoopCloser* self;
    std::function<double(std::chrono::steady_clock::time_point)> to_s;
    ~WindowCloser() {
      std::lock_guard<std::mutex> lock(self->stats_mutex_);
      self->stats_.global_ba_running = false;
      self->stats_.global_ba_windows_s.back().second = to_s(std::chrono::steady_clock::now());
    }
  } window_closer{this, steady_s};
  {
    ceres::Problem::Options problem_options;
    problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem problem(problem_options);
    PoseManifold manifold;
    const double delta_mono = std::sqrt(optimizer_.chi2_mono),
                 delta_stereo = std::sqrt(optimizer_.chi2_stereo);
    for (const Observation& o : observations) {
      ceres::CostFunction* cost = o.stereo
                                      ? static_cast<ceres::CostFunction*>(
                                            new StereoBACost(o.measurement, o.sqrt_info, model))
                                      : new MonoBACost(o.measurement.head<2>(), o.sqrt_info, model);
      problem.AddResidualBlock(cost, new ceres::HuberLoss(o.stereo ? delta_stereo : delta_mono),
                               poses[o.kf_id].data(), points[o.point_id].data());
    }
    for (auto& [id, pose] : poses) {
      if (!problem.HasParameterBlock(pose.data())) continue;
      problem.SetManifold(pose.data(), &manifold);
      if (id == first_kf) problem.SetParameterBlockConstant(pose.data());
    }
    struct Abort : ceres::IterationCallback {
      explicit Abort(const std::atomic<bool>* flag) : flag(flag) {}
      ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
        return flag->load() ? ceres::SOLVER_ABORT : ceres::SOLVER_CONTINUE;
      }
      const std::atomic<bool>* flag;
    } abort(&global_ba_abort_);
    ceres::Solver::Options solver_options;
    solver_options.linear_solver_type = ceres::SPARSE_SCHUR;
    solver_options.max_num_iterations = options_.global_ba_iterations;
    solver_options.num_threads = 1;
    solver_options.logging_type = ceres::SILENT;
    solver_options.callbacks.push_back(&abort);
    ceres::Solver::Summary summary;
    ceres::Solve(solver_options, &problem, &summary);
    if (global_ba_abort_.load() || summary.termination_type == ceres::USER_FAILURE ||
        summary.termination_type == ceres::FAILURE) {
      std::lock_guard<std::mutex> lock(stats_mutex_);
      stats_.global_ba_discarded++;
      return;
    }
  }
  std::vector<int64_t> moved;
  {
    std::lock_guard<std::mutex> lock(map_->mutex());
    if (map_->CorrectionEpoch() != epoch) {
      std::lock_guard<std::mutex> stats_lock(stats_mutex_);
      stats_.global_ba_discarded++;
      return;
    }
    // Keyframes in the problem take its poses; newer ones follow their parent (chain) by the same
    // world correction; points not in the problem follow their reference keyframe.
    std::map<int64_t, Rigid3d> after;
    for (const auto& [id, p] : poses) after[id] = PoseFromParameters(p.data());
    std::map<int64_t, Rigid3d> old_pose;
    for (const auto& [id, k] : map_->keyframes()) {
      old_pose[id] = k->cam_from_world;
      if (after.count(id)) continue;
      // The anchor is a keyframe of the problem (in `before`): keyframes added to `after` by this
      // loop were not solved and have no `before` pose.
      int64_t anchor = k->parent_id;
      for (int guard = 0; guard < 1000 && anchor >= 0 && !before.count(anchor); ++guard) {
        auto parent = map_->GetKeyFrame(anchor);
        anchor = parent ? parent->parent_id : -1;
      }
      if (anchor < 0 || !before.count(anchor)) continue;
      after[id] = k->cam_from_world * before.at(anchor).Inverse() * after.at(anchor);
    }
    for (const auto& [pid, mp] : map_->map_points()) {
      if (mp->bad) continue;
      auto solved = points.find(pid);
      if (solved != points.end()) {
        mp->position = solved->second;
      } else {
        auto ref = after.find(mp->ref_kf_id);
        auto old = old_pose.find(mp->ref_kf_id);
        if (ref == after.end() || old == old_pose.end()) continue;
        mp->position = ref->second.Inverse() * (old->second * mp->position);
      }
    }
    for (const auto& [id, k] : map_->keyframes()) {
      auto a = after.find(id);
      if (a == after.end()) continue;
      k->cam_from_world = a->second;
      moved.push_back(id);
    }
    for (const auto& [pid, mp] : map_->map_points())
      if (!mp->bad) map_->UpdateNormalAndDepth(*mp);
    map_->BumpCorrectionEpoch();
  }
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    stats_.global_ba_runs++;
    stats_.global_ba_ms_total += ms;
  }
  LOG_INFO << "global BA: " << poses.size() << " keyframes, " << points.size() << " points, "
           << observations.size() << " observations, " << ms << " ms (wall, its own thread)";
  Report(moved);
}

}  // namespace dygslam
