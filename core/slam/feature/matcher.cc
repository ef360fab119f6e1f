#include "core/slam/feature/matcher.h"

#include <algorithm>
#include <cmath>

namespace dygslam {
namespace {
constexpr int kHistogramBins = 30;

float AngleDifference(float a, float b) {
  float d = a - b;
  if (d < 0) d += 360.f;
  return d;
}
}  // namespace

std::vector<int> RotationConsistencyOutliers(const std::vector<float>& rotations) {
  std::vector<std::vector<int>> bins(kHistogramBins);
  for (int i = 0; i < static_cast<int>(rotations.size()); ++i) {
    int b = static_cast<int>(std::lround(rotations[i] * kHistogramBins / 360.f));
    if (b == kHistogramBins) b = 0;
    bins[std::clamp(b, 0, kHistogramBins - 1)].push_back(i);
  }
  int best[3] = {-1, -1, -1};
  for (int b = 0; b < kHistogramBins; ++b) {
    const size_t s = bins[b].size();
    if (best[0] < 0 || s > bins[best[0]].size()) {
      best[2] = best[1];
      best[1] = best[0];
      best[0] = b;
    } else if (best[1] < 0 || s > bins[best[1]].size()) {
      best[2] = best[1];
      best[1] = b;
    } else if (best[2] < 0 || s > bins[best[2]].size()) {
      best[2] = b;
    }
  }
  // Secondary bins count only if they are not much smaller than the dominant one.
  const size_t top = best[0] >= 0 ? bins[best[0]].size() : 0;
  std::vector<bool> keep(kHistogramBins, false);
  if (best[0] >= 0) keep[best[0]] = true;
  for (int k = 1; k < 3; ++k) {
    if (best[k] >= 0 && bins[best[k]].size() >= 0.1 * top) keep[best[k]] = true;
  }
  std::vector<int> drop;
  for (int b = 0; b < kHistogramBins; ++b) {
    if (!keep[b]) drop.insert(drop.end(), bins[b].begin(), bins[b].end());
  }
  return drop;
}

int Matcher::SearchByProjection(Frame& current, const Frame& last, double radius_px) const {
  const CameraGeometry& g = *current.geometry;
  const Rigid3d& cw = current.cam_from_world;
  std::vector<int> matched_idx;
  std::vector<float> rotations;
  for (size_t i = 0; i < last.size(); ++i) {
    const auto& mp = last.map_points[i];
    if (!mp || last.outlier[i]) continue;
    const Eigen::Vector3d p = cw * mp->position;
    if (p.z() <= 0) continue;
    const double inv_z = 1.0 / p.z();
    const double u = g.camera.fx * p.x() * inv_z + g.camera.cx;
    const double v = g.camera.fy * p.y() * inv_z + g.camera.cy;
    if (!g.InBounds(u, v)) continue;
    const int level = last.undistorted[i].octave;
    const double r = radius_px * g.scales[level];
    const auto candidates = current.grid.Query(current.undistorted, u, v, r, std::max(0, level - 1), level + 1);
    int best_dist = 256, best_idx = -1;
    const double ur = u - g.bf * inv_z;
    for (int c : candidates) {
      if (current.map_points[c]) continue;
      if (current.u_right[c] > 0 && std::abs(ur - current.u_right[c]) > r) continue;
      const int d = HammingDistance(mp->descriptor, current.descriptors[c]);
      if (d < best_dist) {
        best_dist = d;
        best_idx = c;
      }
    }
    const int max_distance = (best_idx >= 0 && current.in_dynamic_region[best_idx]) ? options_.th_low : options_.th_high;
    if (best_idx >= 0 && best_dist <= max_distance) {
      current.map_points[best_idx] = mp;
      matched_idx.push_back(best_idx);
      rotations.push_back(AngleDifference(last.undistorted[i].angle, current.undistorted[best_idx].angle));
    }
  }
  int n = static_cast<int>(matched_idx.size());
  if (options_.check_orientation) {
    for (int k : RotationConsistencyOutliers(rotations)) {
      current.map_points[matched_idx[k]] = nullptr;
      --n;
    }
  }
  return n;
}

int Matcher::SearchByProjection(Frame& frame, const std::vector<std::shared_ptr<MapPoint>>& points,
                                double radius_factor) const {
  const CameraGeometry& g = *frame.geometry;
  int n = 0;
  for (const auto& mp : points) {
    if (!mp->track_in_view || mp->bad) continue;
    const int level = mp->track_scale_level;
    double r = (mp->track_view_cos > 0.998 ? 2.5 : 4.0) * radius_factor * g.scales[level];
    const auto candidates =
        frame.grid.Query(frame.undistorted, mp->track_proj_x, mp->track_proj_y, r, level - 1, level);
    int best = 256, second = 256, best_level = -1, second_level = -1, best_idx = -1;
    for (int c : candidates) {
      if (frame.map_points[c] && frame.map_points[c]->NumObservations() > 0) continue;
      if (frame.u_right[c] > 0 && std::abs(mp->track_proj_xr - frame.u_right[c]) > r) continue;
      const int d = HammingDistance(mp->descriptor, frame.descriptors[c]);
      if (d < best) {
        second = best;
        second_level = best_level;
        best = d;
        best_level = frame.undistorted[c].octave;
        best_idx = c;
      } else if (d < second) {
        second = d;
        second_level = frame.undistorted[c].octave;
      }
    }
    // Features inside detection boxes that the filter kept must match more strictly: a
    // background point hidden behind a person projects onto the person's texture.
    const int max_distance = (best_idx >= 0 && frame.in_dynamic_region[best_idx]) ? options_.th_low : options_.th_high;
    if (best_idx >= 0 && best <= max_distance) {
      if (best_level == second_level && best > options_.nn_ratio * second) continue;
      frame.map_points[best_idx] = mp;
      ++n;
    }
  }
  return n;
}

int Matcher::SearchByDescriptors(const KeyFrame& kf, Frame& frame, double ratio) const {
  std::vector<int> matched_idx;
  std::vector<float> rotations;
  std::vector<int> best_for_frame(frame.size(), 256);
  std::vector<int> owner(frame.size(), -1);
  for (size_t i = 0; i < kf.size(); ++i) {
    const auto& mp = kf.map_points[i];
    if (!mp || mp->bad) continue;
    int best = 256, second = 256, best_idx = -1;
    for (size_t c = 0; c < frame.size(); ++c) {
      const int d = HammingDistance(kf.descriptors[i], frame.descriptors[c]);
      if (d < best) {
        second = best;
        best = d;
        best_idx = static_cast<int>(c);
      } else if (d < second) {
        second = d;
      }
    }
    if (best_idx < 0 || best > options_.th_low || best > ratio * second) continue;
    if (best >= best_for_frame[best_idx]) continue;
    best_for_frame[best_idx] = best;
    owner[best_idx] = static_cast<int>(i);
  }
  for (size_t c = 0; c < frame.size(); ++c) {
    if (owner[c] < 0) continue;
    frame.map_points[c] = kf.map_points[owner[c]];
    matched_idx.push_back(static_cast<int>(c));
    rotations.push_back(AngleDifference(kf.undistorted[owner[c]].angle, frame.undistorted[c].angle));
  }
  int n = static_cast<int>(matched_idx.size());
  if (options_.check_orientation) {
    for (int k : RotationConsistencyOutliers(rotations)) {
      frame.map_points[matched_idx[k]] = nullptr;
      --n;
    }
  }
  return n;
}

int Matcher::SearchByProjection(Frame& frame, const KeyFrame& kf,
                                const std::set<const MapPoint*>& already_found, double radius_px,
                                int max_distance) const {
  const CameraGeometry& g = *frame.geometry;
  const Eigen::Vector3d center = frame.CameraCenter();
  int n = 0;
  for (size_t i = 0; i < kf.size(); ++i) {
    const auto& mp = kf.map_points[i];
    if (!mp || mp->bad) continue;
    if (already_found.count(mp.get())) continue;
    const Eigen::Vector3d p = frame.cam_from_world * mp->position;
    if (p.z() <= 0) continue;
    const double u = g.camera.fx * p.x() / p.z() + g.camera.cx;
    const double v = g.camera.fy * p.y() / p.z() + g.camera.cy;
    if (!g.InBounds(u, v)) continue;
    const double dist = (mp->position - center).norm();
    if (dist < 0.8 * mp->min_distance || dist > 1.2 * mp->max_distance) continue;
    const int level = mp->PredictScale(dist, g);
    const auto candidates = frame.grid.Query(frame.undistorted, u, v, radius_px * g.scales[level],
                                             std::max(0, level - 1), level + 1);
    int best = 256, best_idx = -1;
    for (int c : candidates) {
      if (frame.map_points[c]) continue;
      const int d = HammingDistance(mp->descriptor, frame.descriptors[c]);
      if (d < best) {
        best = d;
        best_idx = c;
      }
    }
    if (best_idx >= 0 && best <= max_distance) {
      frame.map_points[best_idx] = mp;
      ++n;
    }
  }
  return n;
}

std::vector<std::pair<int, int>> Matcher::SearchForTriangulation(const KeyFrame& kf1, const KeyFrame& kf2) const {
  // Features of kf1 with a depth measurement are projected into kf2 over the depth range
  // [0.9 d, 1.1 d] (a segment of the epipolar line); candidates near the segment are compared.
  const CameraGeometry& g = *kf1.geometry;
  const Rigid3d c2_from_c1 = kf2.cam_from_world * kf1.cam_from_world.Inverse();
  std::vector<std::pair<int, int>> matches;
  std::vector<int> best_for_2(kf2.size(), 256), owner(kf2.size(), -1);
  std::vector<float> rotations;
  for (size_t i = 0; i < kf1.size(); ++i) {
    if (kf1.map_points[i] || !kf1.CanSeedPoint(i)) continue;
    const cv::Point2f& p1 = kf1.undistorted[i].pt;
    const double d = kf1.depth[i];
    const Eigen::Vector3d a = c2_from_c1 * g.camera.Unproject(p1.x, p1.y, 0.9 * d);
    const Eigen::Vector3d b = c2_from_c1 * g.camera.Unproject(p1.x, p1.y, 1.1 * d);
    if (a.z() <= 0 || b.z() <= 0) continue;
    const Eigen::Vector2d ua = g.camera.Project(a), ub = g.camera.Project(b);
    const Eigen::Vector2d mid = 0.5 * (ua + ub);
    const int level = kf1.undistorted[i].octave;
    const double tol = 2.0 * std::sqrt(g.sigma2[level]) + 1.0;
    const double r = 0.5 * (ua - ub).norm() + tol;
    if (!g.InBounds(mid.x(), mid.y())) continue;
    const auto candidates = kf2.grid.Query(kf2.undistorted, mid.x(), mid.y(), r, std::max(0, level - 1), level + 1);
    const Eigen::Vector2d dir = (ub - ua).norm() > 1e-9 ? Eigen::Vector2d((ub - ua).normalized()) : Eigen::Vector2d(1, 0);
    int best = 256, best_idx = -1;
    for (int c : candidates) {
      if (kf2.map_points[c] || kf2.in_dynamic_region[c]) continue;
      const Eigen::Vector2d q(kf2.undistorted[c].pt.x, kf2.undistorted[c].pt.y);
      const Eigen::Vector2d rel = q - ua;
      const double along = rel.dot(dir);
      const double across = std::abs(rel.x() * dir.y() - rel.y() * dir.x());
      if (across > tol || along < -tol || along > (ub - ua).norm() + tol) continue;
      const int dist = HammingDistance(kf1.descriptors[i], kf2.descriptors[c]);
      if (dist < best) {
        best = dist;
        best_idx = c;
      }
    }
    if (best_idx < 0 || best > options_.th_low) continue;
    if (best >= best_for_2[best_idx]) continue;
    best_for_2[best_idx] = best;
    owner[best_idx] = static_cast<int>(i);
  }
  for (size_t c = 0; c < kf2.size(); ++c) {
    if (owner[c] < 0) continue;
    matches.push_back({owner[c], static_cast<int>(c)});
    rotations.push_back(AngleDifference(kf1.undistorted[owner[c]].angle, kf2.undistorted[c].angle));
  }
  if (options_.check_orientation) {
    auto drop = RotationConsistencyOutliers(rotations);
    std::sort(drop.rbegin(), drop.rend());
    for (int k : drop) matches.erase(matches.begin() + k);
  }
  return matches;
}

int Matcher::Fuse(Map& map, const std::shared_ptr<KeyFrame>& kf,
                  const std::vector<std::shared_ptr<MapPoint>>& points, double radius_px) const {
  const CameraGeometry& g = *kf->geometry;
  const Eigen::Vector3d center = kf->CameraCenter();
  int fused = 0;
  for (const auto& mp : points) {
    if (!mp || mp->bad || mp->observations.count(kf->id)) continue;
    const Eigen::Vector3d p = kf->cam_from_world * mp->position;
    if (p.z() <= 0) continue;
    const double inv_z = 1.0 / p.z();
    const double u = g.camera.fx * p.x() * inv_z + g.camera.cx;
    const double v = g.camera.fy * p.y() * inv_z + g.camera.cy;
    if (!g.InBounds(u, v)) continue;
    const double ur = u - g.bf * inv_z;
    const Eigen::Vector3d po = mp->position - center;
    const double dist = po.norm();
    if (dist < 0.8 * mp->min_distance || dist > 1.2 * mp->max_distance) continue;
    if (po.dot(mp->normal) < 0.5 * dist) continue;
    const int level = mp->PredictScale(dist, g);
    const double r = radius_px * g.scales[level];
    const auto candidates = kf->grid.Query(kf->undistorted, u, v, r);
    int best = 256, best_idx = -1;
    for (int c : candidates) {
      const cv::KeyPoint& kp = kf->undistorted[c];
      if (kp.octave < level - 1 || kp.octave > level) continue;
      const double inv_sigma2 = g.inv_sigma2[kp.octave];
      const double ex = u - kp.pt.x, ey = v - kp.pt.y;
      if (kf->u_right[c] >= 0) {
        const double er = ur - kf->u_right[c];
        if ((ex * ex + ey * ey + er * er) * inv_sigma2 > 7.8) continue;
      } else if ((ex * ex + ey * ey) * inv_sigma2 > 5.99) {
        continue;
      }
      const int d = HammingDistance(mp->descriptor, kf->descriptors[c]);
      if (d < best) {
        best = d;
        best_idx = c;
      }
    }
    if (best_idx < 0 || best > options_.th_low) continue;
    auto existing = kf->map_points[best_idx];
    if (existing && !existing->bad) {
      if (existing == mp) continue;
      if (existing->NumObservations() > mp->NumObservations()) {
        map.Replace(mp, existing);
      } else {
        map.Replace(existing, mp);
      }
    } else {
      map.AddObservation(mp, kf, best_idx);
    }
    ++fused;
  }
  return fused;
}

}  // namespace dygslam

namespace dygslam {
namespace {

// Shared body of the two BoW searches: for each feature i of `a` with a usable map point, the
// best feature of `b` in the same direct-index node (Hamming <= th_low, ratio test), one owner
// per feature of `b`, then the rotation-consistency check. Returns (b index -> a index).
template <typename UsableA, typename UsableB>
std::vector<std::pair<int, int>> MatchWithinNodes(const FeatureVector& fa, const std::vector<Descriptor>& da,
                                                  const std::vector<cv::KeyPoint>& ka, const FeatureVector& fb,
                                                  const std::vector<Descriptor>& db, const std::vector<cv::KeyPoint>& kb,
                                                  const MatcherOptions& options, double ratio, UsableA usable_a,
                                                  UsableB usable_b) {
  std::vector<int> best_for_b(db.size(), 256), owner(db.size(), -1);
  auto ia = fa.begin();
  auto ib = fb.begin();
  while (ia != fa.end() && ib != fb.end()) {
    if (ia->first < ib->first) {
      ia = fa.lower_bound(ib->first);
      continue;
    }
    if (ib->first < ia->first) {
      ib = fb.lower_bound(ia->first);
      continue;
    }
    for (int i : ia->second) {
      if (!usable_a(i)) continue;
      int best = 256, second = 256, best_idx = -1;
      for (int c : ib->second) {
        if (!usable_b(c)) continue;
        const int d = HammingDistance(da[i], db[c]);
        if (d < best) {
          second = best;
          best = d;
          best_idx = c;
        } else if (d < second) {
          second = d;
        }
      }
      if (best_idx < 0 || best > options.th_low || best > ratio * second) continue;
      if (best >= best_for_b[best_idx]) continue;
      best_for_b[best_idx] = best;
      owner[best_idx] = i;
    }
    ++ia;
    ++ib;
  }
  std::vector<std::pair<int, int>> pairs;
  std::vector<float> rotations;
  for (size_t c = 0; c < db.size(); ++c) {
    if (owner[c] < 0) continue;
    pairs.push_back({static_cast<int>(c), owner[c]});
    rotations.push_back(AngleDifference(ka[owner[c]].angle, kb[c].angle));
  }
  if (options.check_orientation) {
    std::vector<uint8_t> drop(pairs.size(), 0);
    for (int k : RotationConsistencyOutliers(rotations)) drop[k] = 1;
    std::vector<std::pair<int, int>> kept;
    for (size_t k = 0; k < pairs.size(); ++k)
      if (!drop[k]) kept.push_back(pairs[k]);
    pairs.swap(kept);
  }
  return pairs;
}

}  // namespace

int Matcher::SearchByBow(const KeyFrame& kf, Frame& frame, double ratio) const {
  const auto pairs = MatchWithinNodes(
      kf.bow_features, kf.descriptors, kf.undistorted, frame.bow_features, frame.descriptors, frame.undistorted,
      options_, ratio,
      [&](int i) {
        const auto& mp = kf.map_points[i];
        return mp && !mp->bad;
      },
      [](int) { return true; });
  for (const auto& [c, i] : pairs) frame.map_points[c] = kf.map_points[i];
  return static_cast<int>(pairs.size());
}

int Matcher::SearchByBow(const KeyFrame& kf1, const KeyFrame& kf2, double ratio,
                         std::vector<std::shared_ptr<MapPoint>>* matches) const {
  matches->assign(kf1.size(), nullptr);
  const auto pairs = MatchWithinNodes(
      kf2.bow_features, kf2.descriptors, kf2.undistorted, kf1.bow_features, kf1.descriptors, kf1.undistorted,
      options_, ratio,
      [&](int i) {
        const auto& mp = kf2.map_points[i];
        return mp && !mp->bad;
      },
      [&](int c) {
        const auto& mp = kf1.map_points[c];
        return mp && !mp->bad;
      });
  for (const auto& [c, i] : pairs) (*matches)[c] = kf2.map_points[i];
  return static_cast<int>(pairs.size());
}

std::vector<std::pair<int, int>> Matcher::SearchByBow(const KeyFrame& kf1,
                                                      const std::vector<uint8_t>& usable1,
                                                      const KeyFrame& kf2,
                                                      const std::vector<uint8_t>& usable2,
                                                      double ratio) const {
  return MatchWithinNodes(
      kf2.bow_features, kf2.descriptors, kf2.undistorted, kf1.bow_features, kf1.descriptors,
      kf1.undistorted, options_, ratio, [&](int i) { return usable2[i] != 0; },
      [&](int c) { return usable1[c] != 0; });
}

}  // namespace dygslam
