// Descriptor matching between frames, keyframes and map points (guided by projection).
#pragma once

#include <memory>
#include <set>
#include <vector>

#include "core/slam/map/frame.h"
#include "core/slam/map/map.h"

namespace dygslam {

struct MatcherOptions {
  int th_high = 100;        // max Hamming distance for projection matches
  int th_low = 50;          // max Hamming distance for descriptor-only matches
  double nn_ratio = 0.8;    // best / second best
  bool check_orientation = true;
  void Check() const {
    DYGSLAM_CHECK_OPTION(th_low > 0 && th_low <= th_high && th_high <= 256, "Matcher.th_low/th_high");
    DYGSLAM_CHECK_OPTION(nn_ratio > 0 && nn_ratio <= 1, "Matcher.nn_ratio");
  }
};

class Matcher {
 public:
  explicit Matcher(const MatcherOptions& options = {}) : options_(options) {}

  // Projects the map points matched in `last` into `current` (which has a pose guess); search
  // radius = radius_px * scale of the last observation. Returns the number of new matches.
  int SearchByProjection(Frame& current, const Frame& last, double radius_px) const;
  // Projects local map points (with track_* fields filled by the tracker) into the frame.
  int SearchByProjection(Frame& frame, const std::vector<std::shared_ptr<MapPoint>>& points,
                         double radius_factor) const;
  // Descriptor matching of the keyframe's map points against the frame (no pose needed).
  int SearchByDescriptors(const KeyFrame& kf, Frame& frame, double ratio) const;
  // Same as SearchByDescriptors, but features are compared only within the same vocabulary node
  // (direct index: both bow_features must be computed), so the cost no longer grows with the
  // product of the feature counts.
  int SearchByBow(const KeyFrame& kf, Frame& frame, double ratio) const;
  // Map points of kf1 against map points of kf2 within the same vocabulary node (loop closing):
  // matches[i] = kf2's point matched to kf1's feature i (nullptr: none). Returns the count.
  int SearchByBow(const KeyFrame& kf1, const KeyFrame& kf2, double ratio,
                  std::vector<std::shared_ptr<MapPoint>>* matches) const;
  // The same search on copies of the map state: usable1/usable2[i] = 1 where feature i has a
  // usable map point (taken under the map lock; only the keyframes' immutable features are read
  // here, so no lock is needed). Returns (kf1 feature, kf2 feature) pairs.
  std::vector<std::pair<int, int>> SearchByBow(const KeyFrame& kf1,
                                               const std::vector<uint8_t>& usable1,
                                               const KeyFrame& kf2,
                                               const std::vector<uint8_t>& usable2,
                                               double ratio) const;
  // Projects the keyframe's map points using the frame's pose guess (relocalization refinement).
  int SearchByProjection(Frame& frame, const KeyFrame& kf,
                         const std::set<const MapPoint*>& already_found, double radius_px,
                         int max_distance) const;
  // Matches features without map points between two keyframes, guided by kf1's depth (projected
  // into kf2 along the depth uncertainty) or by the epipolar line. Returns index pairs.
  std::vector<std::pair<int, int>> SearchForTriangulation(const KeyFrame& kf1, const KeyFrame& kf2) const;
  // Projects `points` into `kf`; fuses duplicates / adds observations. Returns fused count.
  int Fuse(Map& map, const std::shared_ptr<KeyFrame>& kf,
           const std::vector<std::shared_ptr<MapPoint>>& points, double radius_px) const;

  const MatcherOptions& options() const { return options_; }

 private:
  MatcherOptions options_;
};

// Keeps only matches whose rotation difference falls in the three dominant histogram bins.
// rotations: angle differences in degrees per match; returns indices of matches to drop.
std::vector<int> RotationConsistencyOutliers(const std::vector<float>& rotations);

}  // namespace dygslam
