#include "core/slam/map/map.h"

#include <algorithm>
#include <cmath>

namespace dygslam {

int MapPoint::PredictScale(double distance, const CameraGeometry& g) const {
  const double ratio = max_distance / distance;
  int level = static_cast<int>(std::ceil(std::log(ratio) / g.log_scale_factor));
  return std::clamp(level, 0, g.num_levels - 1);
}

KeyFrame::KeyFrame(int64_t kf_id, const Frame& frame)
    : id(kf_id),
      frame_id(frame.id),
      stamp(frame.stamp),
      geometry(frame.geometry),
      keypoints(frame.keypoints),
      undistorted(frame.undistorted),
      descriptors(frame.descriptors),
      depth(frame.depth),
      u_right(frame.u_right),
      in_dynamic_region(frame.in_dynamic_region),
      grid(frame.grid),
      bow_vector(frame.bow_vector),
      bow_features(frame.bow_features),
      cam_from_world(frame.cam_from_world),
      map_points(frame.map_points) {
  ++live_count_;
}

MapStatistics Map::Statistics() const {
  std::lock_guard<std::mutex> lock(mutex_);
  MapStatistics s;
  s.keyframes = keyframes_.size();
  s.culled_keyframes = culled_.size();
  s.map_points = points_.size();
  s.live_keyframe_objects = KeyFrame::LiveCount();
  s.live_point_objects = MapPoint::LiveCount();
  return s;
}

std::vector<int64_t> KeyFrame::BestCovisibles(int n) const {
  if (static_cast<int>(ordered_connections.size()) <= n) return ordered_connections;
  return std::vector<int64_t>(ordered_connections.begin(), ordered_connections.begin() + n);
}

int KeyFrame::NumTrackedPoints(int min_observations) const {
  int n = 0;
  for (const auto& mp : map_points) {
    if (mp && !mp->bad && mp->NumObservations() >= min_observations) ++n;
  }
  return n;
}

Eigen::Vector3d KeyFrame::UnprojectWorld(size_t i) const {
  const cv::Point2f& p = undistorted[i].pt;
  return cam_from_world.Inverse() * geometry->camera.Unproject(p.x, p.y, depth[i]);
}

void Map::AddKeyFrame(const std::shared_ptr<KeyFrame>& kf) { keyframes_[kf->id] = kf; }
void Map::AddMapPoint(const std::shared_ptr<MapPoint>& mp) { points_[mp->id] = mp; }

std::shared_ptr<KeyFrame> Map::GetKeyFrame(int64_t id) const {
  auto it = keyframes_.find(id);
  return it != keyframes_.end() ? it->second : nullptr;
}

void Map::AddObservation(const std::shared_ptr<MapPoint>& mp, const std::shared_ptr<KeyFrame>& kf,
                         int idx) {
  mp->observations[kf->id] = idx;
  kf->map_points[idx] = mp;
}

void Map::EraseObservation(const std::shared_ptr<MapPoint>& mp, int64_t kf_id) {
  auto it = mp->observations.find(kf_id);
  if (it == mp->observations.end()) return;
  auto kf = GetKeyFrame(kf_id);
  if (kf && it->second < static_cast<int>(kf->map_points.size()) &&
      kf->map_points[it->second] == mp) {
    kf->map_points[it->second] = nullptr;
  }
  mp->observations.erase(it);
  if (mp->ref_kf_id == kf_id && !mp->observations.empty())
    mp->ref_kf_id = mp->observations.begin()->first;
  // A point seen by fewer than two keyframes carries no constraint: drop it.
  if (mp->observations.size() <= 1) SetBad(mp);
}

void Map::SetBad(const std::shared_ptr<MapPoint>& mp) {
  if (mp->bad) return;
  mp->bad = true;
  for (const auto& [kf_id, idx] : mp->observations) {
    auto kf = GetKeyFrame(kf_id);
    if (kf && idx < static_cast<int>(kf->map_points.size()) && kf->map_points[idx] == mp) {
      kf->map_points[idx] = nullptr;
    }
  }
  mp->observations.clear();
  points_.erase(mp->id);
}

void Map::Replace(const std::shared_ptr<MapPoint>& mp, const std::shared_ptr<MapPoint>& other) {
  if (mp == other || mp->bad) return;
  const auto observations = mp->observations;
  mp->observations.clear();
  mp->bad = true;
  mp->replaced_by = other;
  for (const auto& [kf_id, idx] : observations) {
    auto kf = GetKeyFrame(kf_id);
    if (!kf) continue;
    if (other->observations.count(kf_id) == 0) {
      kf->map_points[idx] = other;
      other->observations[kf_id] = idx;
    } else {
      kf->map_points[idx] = nullptr;
    }
  }
  other->found_count += mp->found_count;
  other->visible_count += mp->visible_count;
  ComputeDistinctiveDescriptor(*other);
  points_.erase(mp->id);
}

void Map::UpdateNormalAndDepth(MapPoint& mp) const {
  if (mp.bad || mp.observations.empty()) return;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  int n = 0;
  for (const auto& [kf_id, idx] : mp.observations) {
    auto kf = GetKeyFrame(kf_id);
    if (!kf) continue;
    normal += (mp.position - kf->CameraCenter()).normalized();
    ++n;
  }
  auto ref = GetKeyFrame(mp.ref_kf_id);
  if (!ref || mp.observations.count(mp.ref_kf_id) == 0) {
    mp.ref_kf_id = mp.observations.begin()->first;
    ref = GetKeyFrame(mp.ref_kf_id);
  }
  if (!ref || n == 0) return;
  const double dist = (mp.position - ref->CameraCenter()).norm();
  const int level = ref->undistorted[mp.observations.at(mp.ref_kf_id)].octave;
  const auto& g = *ref->geometry;
  mp.max_distance = dist * g.scales[level];
  mp.min_distance = mp.max_distance / g.scales[g.num_levels - 1];
  mp.normal = normal.normalized();
}

void Map::ComputeDistinctiveDescriptor(MapPoint& mp) const {
  std::vector<const Descriptor*> descs;
  for (const auto& [kf_id, idx] : mp.observations) {
    auto kf = GetKeyFrame(kf_id);
    if (kf) descs.push_back(&kf->descriptors[idx]);
  }
  if (descs.empty()) return;
  // The descriptor with the least median distance to the others.
  const size_t n = descs.size();
  int best_median = 1 << 30;
  size_t best = 0;
  std::vector<int> d(n);
  for (size_t i = 0; i < n; ++i) {
    for (size_t j = 0; j < n; ++j) d[j] = HammingDistance(*descs[i], *descs[j]);
    std::nth_element(d.begin(), d.begin() + (n - 1) / 2, d.end());
    const int median = d[(n - 1) / 2];
    if (median < best_median) {
      best_median = median;
      best = i;
    }
  }
  mp.descriptor = *descs[best];
}

void Map::UpdateConnections(const std::shared_ptr<KeyFrame>& kf) {
  std::map<int64_t, int> counts;
  for (const auto& mp : kf->map_points) {
    if (!mp || mp->bad) continue;
    for (const auto& [other_id, idx] : mp->observations) {
      if (other_id != kf->id) counts[other_id]++;
    }
  }
  // Keep links with >= 15 shared points; if none, the single best link.
  constexpr int kMinWeight = 15;
  int64_t best_id = -1;
  int best_weight = 0;
  std::map<int64_t, int> weights;
  for (const auto& [other_id, w] : counts) {
    if (keyframes_.count(other_id) == 0) continue;
    if (w > best_weight) {
      best_weight = w;
      best_id = other_id;
    }
    if (w >= kMinWeight) weights[other_id] = w;
  }
  if (weights.empty() && best_id >= 0) weights[best_id] = best_weight;
  // Remove stale back links, then add the new ones.
  for (const auto& [other_id, w] : kf->connection_weights) {
    auto other = GetKeyFrame(other_id);
    if (other) other->connection_weights.erase(kf->id);
  }
  kf->connection_weights = weights;
  auto order = [](const std::map<int64_t, int>& w) {
    std::vector<std::pair<int, int64_t>> v;
    for (const auto& [id, weight] : w) v.push_back({weight, id});
    std::sort(v.begin(), v.end(), [](const auto& a, const auto& b) {
      return a.first != b.first ? a.first > b.first : a.second < b.second;
    });
    std::vector<int64_t> ids;
    for (const auto& p : v) ids.push_back(p.second);
    return ids;
  };
  for (const auto& [other_id, w] : weights) {
    auto other = GetKeyFrame(other_id);
    if (!other) continue;
    other->connection_weights[kf->id] = w;
    other->ordered_connections = order(other->connection_weights);
  }
  kf->ordered_connections = order(weights);
  if (kf->parent_id < 0 && kf->id != keyframes_.begin()->first && best_id >= 0)
    kf->parent_id = best_id;
}

void Map::SetBad(const std::shared_ptr<KeyFrame>& kf) {
  if (kf->bad || kf->not_erase || kf->id == keyframes_.begin()->first) return;
  for (const auto& [other_id, w] : kf->connection_weights) {
    auto other = GetKeyFrame(other_id);
    if (!other) continue;
    other->connection_weights.erase(kf->id);
    std::vector<int64_t> ordered;
    for (int64_t id : other->ordered_connections)
      if (id != kf->id) ordered.push_back(id);
    other->ordered_connections = ordered;
  }
  for (size_t i = 0; i < kf->map_points.size(); ++i) {
    auto mp = kf->map_points[i];
    if (mp) EraseObservation(mp, kf->id);
  }
  // New parent: the best covisible active keyframe, else the existing parent, else the first.
  int64_t parent = -1;
  for (int64_t id : kf->ordered_connections) {
    if (keyframes_.count(id)) {
      parent = id;
      break;
    }
  }
  if (parent < 0 && kf->parent_id >= 0 && keyframes_.count(kf->parent_id)) parent = kf->parent_id;
  if (parent < 0) parent = keyframes_.begin()->first;
  for (auto& [id, other] : keyframes_) {
    if (other->parent_id == kf->id) other->parent_id = parent;
  }
  kf->parent_id = parent;
  kf->cam_from_parent = kf->cam_from_world * GetKeyFrame(parent)->cam_from_world.Inverse();
  kf->connection_weights.clear();
  kf->ordered_connections.clear();
  kf->bad = true;
  culled_[kf->id] = CulledKeyFrame{parent, kf->cam_from_parent};
  keyframes_.erase(kf->id);
}

int64_t Map::ActiveKeyFrameId(int64_t kf_id) const {
  int64_t id = kf_id;
  for (int guard = 0; guard < 1000000; ++guard) {
    if (keyframes_.count(id)) return id;
    auto culled = culled_.find(id);
    if (culled == culled_.end()) return -1;
    id = culled->second.parent_id;
  }
  return -1;
}

Rigid3d Map::ResolvedPose(int64_t kf_id) const {
  // Walk up the parents of culled keyframes to an active one.
  Rigid3d cam_from_active = Rigid3d::Identity();
  int64_t id = kf_id;
  for (int guard = 0; guard < 1000000; ++guard) {
    auto active = keyframes_.find(id);
    if (active != keyframes_.end()) return cam_from_active * active->second->cam_from_world;
    auto culled = culled_.find(id);
    if (culled == culled_.end()) break;
    cam_from_active = cam_from_active * culled->second.cam_from_parent;
    id = culled->second.parent_id;
  }
  return cam_from_active;
}

}  // namespace dygslam
