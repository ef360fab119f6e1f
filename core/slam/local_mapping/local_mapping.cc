#include "core/slam/local_mapping/local_mapping.h"

#include <Eigen/SVD>
#include <atomic>
#include <chrono>
#include <cmath>
#include <optional>
#include <set>

#include "core/base/memory.h"

namespace dygslam {

namespace {

double MsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

}  // namespace

LocalMapper::LocalMapper(std::shared_ptr<Map> map, const LocalMappingOptions& options,
                         bool threaded)
    : map_(std::move(map)),
      options_(options),
      matcher_(options.matcher),
      threaded_(threaded),
      solver_([this](std::shared_ptr<Job>& job) { Solve(*job, options_.optimizer); }, threaded) {
  options_.Check();
}

LocalMapper::~LocalMapper() { Finish(); }

void LocalMapper::SetPosesChangedCallback(MapChangedCallback callback) {
  std::lock_guard<std::mutex> lock(callback_mutex_);
  poses_changed_ = std::move(callback);
}

void LocalMapper::SetKeyFrameDoneCallback(KeyFrameDoneCallback callback) {
  std::lock_guard<std::mutex> lock(callback_mutex_);
  keyframe_done_ = std::move(callback);
}

void LocalMapper::Solve(Job& job, const OptimizerOptions& options) {
  if (job.bundle.empty()) return;
  const auto start = std::chrono::steady_clock::now();
  SolveBundle(job.bundle, options, options.ba_iterations_first, options.ba_iterations_second);
  job.solve_ms = MsSince(start);
}

void LocalMapper::InsertKeyFrame(std::shared_ptr<KeyFrame> kf) {
  if (pending_) {
    {
      std::lock_guard<std::mutex> lock(stats_mutex_);
      stats_.early_landings++;
    }
    Land();
  }
  const auto start = std::chrono::steady_clock::now();
  auto job = std::make_shared<Job>();
  job->kf = kf;
  job->due_frame = kf->frame_id + options_.ba_lag_frames;
  {
    std::lock_guard<std::mutex> lock(map_->mutex());
    if (kf->bad) return;
    // Points this keyframe created are "recent": they must prove themselves.
    for (const auto& mp : kf->map_points) {
      if (mp && !mp->bad && mp->first_kf_id == kf->id) recent_points_.push_back(mp);
    }
  }
  CullRecentPoints(kf);
  CreateNewMapPoints(kf);
  FuseWithNeighbors(kf);
  {
    std::lock_guard<std::mutex> lock(map_->mutex());
    // Reported as moved whether or not the BA changes them (the map re-reads their poses).
    job->window.push_back(kf->id);
    for (int64_t id : kf->ordered_connections) job->window.push_back(id);
    if (map_->NumKeyFrames() > 2) job->bundle = PrepareLocalBundle(*map_, kf);
  }
  job->insert_ms = MsSince(start);
  pending_ = job;
  if (options_.ba_lag_frames == 0) {
    Land();  // solved and landed here, at once
  } else if (threaded_) {
    solver_.Push(job);  // solved on the mapping thread; lands at the due frame
  }                     // unthreaded: solved and landed here at the due frame (BeginFrame)
}

void LocalMapper::BeginFrame(int64_t frame_id) {
  if (pending_ && frame_id >= pending_->due_frame) Land();
}

void LocalMapper::Land() {
  std::shared_ptr<Job> job = std::move(pending_);
  pending_.reset();
  if (!job) return;
  double waited_ms = 0;
  if (threaded_ && options_.ba_lag_frames > 0) {
    if (!solver_.Idle()) {
      const auto start = std::chrono::steady_clock::now();
      solver_.WaitIdle(std::chrono::hours(24));
      waited_ms = MsSince(start);
    }
  } else {
    Solve(*job, options_.optimizer);
  }
  const auto start = std::chrono::steady_clock::now();
  std::vector<int64_t> moved, culled;
  {
    std::lock_guard<std::mutex> lock(map_->mutex());
    ApplyBundle(*map_, job->bundle);
  }
  moved = job->window;
  if (options_.cull_keyframes) CullKeyFrames(job->kf, &culled);
  const double land_ms = MsSince(start);
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    const double ms = job->insert_ms + job->solve_ms + land_ms;
    stats_.keyframes_processed++;
    stats_.total_ms += ms;
    stats_.per_keyframe_ms.push_back(ms);
    stats_.insert_ms.push_back(job->insert_ms + land_ms);
    stats_.solve_ms.push_back(job->solve_ms);
    stats_.ba_keyframes.push_back(
        static_cast<int>(job->bundle.poses.size() - job->bundle.fixed.size()));
    stats_.ba_observations.push_back(static_cast<int>(job->bundle.observations.size()));
    if (waited_ms > 0) {
      stats_.late_bundle_adjustments++;
      stats_.late_wait_ms += waited_ms;
    }
  }
  MapChangedCallback callback;
  KeyFrameDoneCallback done;
  {
    std::lock_guard<std::mutex> lock(callback_mutex_);
    callback = poses_changed_;
    done = keyframe_done_;
  }
  if (callback && (!moved.empty() || !culled.empty())) callback(moved, culled);
  if (done) done(job->kf);
  // Culled keyframes free their features and images in the middle of the heap, where glibc keeps
  // the pages resident: a long run's resident set would creep up with a flat heap in use.
  // The pages are the process's, so the count is too (one per process, any number of mappers).
  static std::atomic<int> culled_since_trim{0};
  constexpr int kTrimEveryCulledKeyFrames = 16;
  if (!culled.empty() &&
      (culled_since_trim += static_cast<int>(culled.size())) >= kTrimEveryCulledKeyFrames) {
    culled_since_trim = 0;
    ReleaseFreedMemory();
  }
}

void LocalMapper::Finish() {
  Land();
  solver_.Finish();
}

LocalMappingStats LocalMapper::stats() const {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  return stats_;
}

void LocalMapper::CullRecentPoints(const std::shared_ptr<KeyFrame>& kf) {
  std::lock_guard<std::mutex> lock(map_->mutex());
  int culled = 0;
  for (auto it = recent_points_.begin(); it != recent_points_.end();) {
    const auto& mp = *it;
    if (mp->bad) {
      it = recent_points_.erase(it);
    } else if (mp->FoundRatio() < options_.min_found_ratio) {
      map_->SetBad(mp);
      ++culled;
      it = recent_points_.erase(it);
    } else if (kf->id - mp->first_kf_id >= 2 && mp->NumObservations() <= 1) {
      map_->SetBad(mp);
      ++culled;
      it = recent_points_.erase(it);
    } else if (kf->id - mp->first_kf_id >= 3) {
      it = recent_points_.erase(it);
    } else {
      ++it;
    }
  }
  std::lock_guard<std::mutex> slock(stats_mutex_);
  stats_.points_culled += culled;
}

namespace {

// The world position of the match (i1 of kf1, i2 of kf2): triangulated when the viewing rays
// have parallax, else kf1's depth of i1; nullopt when neither gives one.
std::optional<Eigen::Vector3d> TriangulateMatch(const KeyFrame& kf1, int i1, const KeyFrame& kf2,
                                                int i2) {
  const PinholeCamera& cam = kf1.geometry->camera;
  const cv::KeyPoint& k1 = kf1.undistorted[i1];
  const cv::KeyPoint& k2 = kf2.undistorted[i2];
  const Eigen::Vector3d x1((k1.pt.x - cam.cx) / cam.fx, (k1.pt.y - cam.cy) / cam.fy, 1.0);
  const Eigen::Vector3d x2((k2.pt.x - cam.cx) / cam.fx, (k2.pt.y - cam.cy) / cam.fy, 1.0);
  // Parallax between the viewing rays decides: triangulate, or trust the depth.
  const Eigen::Vector3d ray1 = kf1.cam_from_world.rotation.conjugate() * x1;
  const Eigen::Vector3d ray2 = kf2.cam_from_world.rotation.conjugate() * x2;
  const double cos_parallax = ray1.dot(ray2) / (ray1.norm() * ray2.norm());
  if (cos_parallax < 0.9998 && cos_parallax > 0) {
    const Eigen::Matrix<double, 3, 4> p1 = kf1.cam_from_world.ToMatrix().topRows<3>();
    const Eigen::Matrix<double, 3, 4> p2 = kf2.cam_from_world.ToMatrix().topRows<3>();
    Eigen::Matrix4d a;
    a.row(0) = x1.x() * p1.row(2) - p1.row(0);
    a.row(1) = x1.y() * p1.row(2) - p1.row(1);
    a.row(2) = x2.x() * p2.row(2) - p2.row(0);
    a.row(3) = x2.y() * p2.row(2) - p2.row(1);
    Eigen::JacobiSVD<Eigen::Matrix4d> svd(a, Eigen::ComputeFullV);
    const Eigen::Vector4d h = svd.matrixV().col(3);
    if (std::abs(h(3)) < 1e-12) return std::nullopt;
    return Eigen::Vector3d(h.head<3>() / h(3));
  }
  if (kf1.depth[i1] > 0) return kf1.UnprojectWorld(i1);
  return std::nullopt;
}

// In front of the keyframe, with a small reprojection error (stereo coordinate included).
bool ReprojectsWell(const KeyFrame& k, int idx, const Eigen::Vector3d& position) {
  const CameraGeometry& g = *k.geometry;
  const PinholeCamera& cam = g.camera;
  const Eigen::Vector3d p = k.cam_from_world * position;
  if (p.z() <= 0) return false;
  const cv::KeyPoint& kp = k.undistorted[idx];
  const double u = cam.fx * p.x() / p.z() + cam.cx, v = cam.fy * p.y() / p.z() + cam.cy;
  double chi2 = (u - kp.pt.x) * (u - kp.pt.x) + (v - kp.pt.y) * (v - kp.pt.y);
  double th = 5.991;
  if (k.u_right[idx] >= 0) {
    const double ur = u - g.bf / p.z();
    chi2 += (ur - k.u_right[idx]) * (ur - k.u_right[idx]);
    th = 7.8;
  }
  return chi2 * g.inv_sigma2[kp.octave] <= th;
}

// The distances from the two camera centres agree with the two keypoints' pyramid levels.
bool ScaleConsistent(const KeyFrame& kf1, int i1, const KeyFrame& kf2, int i2,
                     const Eigen::Vector3d& position) {
  const CameraGeometry& g = *kf1.geometry;
  const double d1 = (position - kf1.CameraCenter()).norm(),
               d2 = (position - kf2.CameraCenter()).norm();
  if (d1 == 0 || d2 == 0) return false;
  const double ratio_dist = d2 / d1;
  const double ratio_octave =
      g.scales[kf1.undistorted[i1].octave] / g.scales[kf2.undistorted[i2].octave];
  const double factor = 1.5 * g.scales[1];
  return !(ratio_dist * factor < ratio_octave || ratio_dist > ratio_octave * factor);
}

}  // namespace

void LocalMapper::CreateNewMapPoints(const std::shared_ptr<KeyFrame>& kf) {
  std::vector<std::shared_ptr<KeyFrame>> neighbors;
  {
    std::lock_guard<std::mutex> lock(map_->mutex());
    for (int64_t id : kf->BestCovisibles(options_.triangulation_neighbors)) {
      auto n = map_->GetKeyFrame(id);
      if (n && !n->bad) neighbors.push_back(n);
    }
  }
  const CameraGeometry& g = *kf->geometry;
  int created = 0;
  for (const auto& other : neighbors) {
    std::lock_guard<std::mutex> lock(map_->mutex());
    if (other->bad || kf->bad) continue;
    const Eigen::Vector3d c1 = kf->CameraCenter(), c2 = other->CameraCenter();
    if ((c2 - c1).norm() < g.bf / g.camera.fx) continue;  // baseline shorter than the sensor's
    for (const auto& [i1, i2] : matcher_.SearchForTriangulation(*kf, *other)) {
      if (kf->map_points[i1] || other->map_points[i2]) continue;
      const std::optional<Eigen::Vector3d> position = TriangulateMatch(*kf, i1, *other, i2);
      if (!position) continue;
      // Checks: in front of both cameras, small reprojection error, consistent scale.
      if (!ReprojectsWell(*kf, i1, *position) || !ReprojectsWell(*other, i2, *position)) continue;
      if (!ScaleConsistent(*kf, i1, *other, i2, *position)) continue;
      auto mp = std::make_shared<MapPoint>(map_->NextMapPointId(), *position, kf->id);
      mp->ref_kf_id = kf->id;
      map_->AddObservation(mp, kf, i1);
      map_->AddObservation(mp, other, i2);
      map_->ComputeDistinctiveDescriptor(*mp);
      map_->UpdateNormalAndDepth(*mp);
      map_->AddMapPoint(mp);
      recent_points_.push_back(mp);
      ++created;
    }
  }
  std::lock_guard<std::mutex> slock(stats_mutex_);
  stats_.points_triangulated += created;
}

void LocalMapper::FuseWithNeighbors(const std::shared_ptr<KeyFrame>& kf) {
  // The map lock is taken per neighbour so tracking is never held up for the whole fusion.
  std::unique_lock<std::mutex> lock(map_->mutex());
  if (kf->bad) return;
  std::vector<std::shared_ptr<KeyFrame>> targets;
  std::set<int64_t> seen = {kf->id};
  for (int64_t id : kf->BestCovisibles(options_.fusion_neighbors)) {
    auto n = map_->GetKeyFrame(id);
    if (!n || n->bad || !seen.insert(id).second) continue;
    targets.push_back(n);
  }
  const size_t first_ring = targets.size();
  for (size_t t = 0; t < first_ring; ++t) {
    for (int64_t id : targets[t]->BestCovisibles(options_.fusion_second_neighbors)) {
      auto n = map_->GetKeyFrame(id);
      if (!n || n->bad || !seen.insert(id).second) continue;
      targets.push_back(n);
    }
  }
  // Current keyframe's points into the neighbours.
  std::vector<std::shared_ptr<MapPoint>> own;
  for (const auto& mp : kf->map_points)
    if (mp && !mp->bad) own.push_back(mp);
  for (const auto& t : targets) {
    lock.unlock();
    lock.lock();
    if (t->bad || kf->bad) continue;
    matcher_.Fuse(*map_, t, own, options_.fusion_radius_px);
  }
  if (kf->bad) return;
  // Neighbours' points into the current keyframe.
  std::vector<std::shared_ptr<MapPoint>> candidates;
  std::set<int64_t> added;
  for (const auto& t : targets) {
    for (const auto& mp : t->map_points) {
      if (mp && !mp->bad && added.insert(mp->id).second) candidates.push_back(mp);
    }
  }
  matcher_.Fuse(*map_, kf, candidates, options_.fusion_radius_px);
  for (const auto& mp : kf->map_points) {
    if (!mp || mp->bad) continue;
    map_->ComputeDistinctiveDescriptor(*mp);
    map_->UpdateNormalAndDepth(*mp);
  }
  map_->UpdateConnections(kf);
}

void LocalMapper::CullKeyFrames(const std::shared_ptr<KeyFrame>& kf,
                                std::vector<int64_t>* culled_ids) {
  std::lock_guard<std::mutex> lock(map_->mutex());
  if (kf->bad) return;
  int culled = 0;
  const std::vector<int64_t> neighbors = kf->ordered_connections;  // SetBad edits the list
  for (int64_t id : neighbors) {
    auto other = map_->GetKeyFrame(id);
    if (!other || other->bad || other->id == map_->keyframes().begin()->first) continue;
    const CameraGeometry& g = *other->geometry;
    int considered = 0, redundant = 0;
    for (size_t i = 0; i < other->map_points.size(); ++i) {
      const auto& mp = other->map_points[i];
      if (!mp || mp->bad) continue;
      if (other->depth[i] > g.close_depth || other->depth[i] < 0) continue;
      ++considered;
      if (mp->NumObservations() <= options_.redundancy_observations) continue;
      const int level = other->undistorted[i].octave;
      int seen_elsewhere = 0;
      for (const auto& [obs_kf_id, idx] : mp->observations) {
        if (obs_kf_id == other->id) continue;
        auto obs_kf = map_->GetKeyFrame(obs_kf_id);
        if (!obs_kf) continue;
        if (obs_kf->undistorted[idx].octave <= level + 1) ++seen_elsewhere;
        if (seen_elsewhere >= options_.redundancy_observations) break;
      }
      if (seen_elsewhere >= options_.redundancy_observations) ++redundant;
    }
    if (considered > 0 && redundant > options_.redundancy_ratio * considered) {
      map_->SetBad(other);
      culled_ids->push_back(other->id);
      ++culled;
    }
  }
  std::lock_guard<std::mutex> slock(stats_mutex_);
  stats_.keyframes_culled += culled;
}

}  // namespace dygslam
