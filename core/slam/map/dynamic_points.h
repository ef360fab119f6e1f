// Per-map-point dynamic flag: a map point whose tracked feature the dynamic filter
// labels dynamic is flagged `is_dynamic` and taken out of the map (Map::SetBad), so tracking,
// local mapping and loop closing no longer use it.
//
// The evidence: the filter matches each feature of frame t to one of frame t-1 (its track);
// when a feature of frame t is labelled dynamic and the feature it continues carried a map
// point in the tracked frame t-1, that point gets a dynamic vote; when the feature is kept
// (static) the point gets a static vote. A point is flagged once it has at least `min_votes`
// dynamic votes and they are at least `min_dynamic_fraction` of its votes (a static point seen
// static for many frames survives one wrong label; a point made on a mover before the filter
// caught it is flagged on the first dynamic label of its track).
//
//   DynamicPointVoter voter(options);
//   voter.Vote(map, previous_points, previous_match, dynamic);   // once per frame
//   voter.flagged();  // what was flagged, with one observation each (for evaluation)
#pragma once

#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <vector>

#include "core/slam/map/map.h"

namespace dygslam {

struct DynamicPointOptions {
  bool enabled = true;
  int min_votes = 1;
  double min_dynamic_fraction = 0.5;
  void Check() const;
};

// One observation of a map point: the frame of a keyframe that observes it and the keypoint's
// pixel there (ground truth look-up on generated data).
struct MapPointLabel {
  int64_t point_id = -1;
  bool is_dynamic = false;
  int64_t frame_id = -1;  // -1: no observation left
  cv::Point2f pixel;
};

class DynamicPointVoter {
 public:
  explicit DynamicPointVoter(const DynamicPointOptions& options);

  // previous_points: the map point of each feature of the filter's previous frame (nullptr:
  // none); previous_match (per feature of this frame): the index of the feature it continues in
  // the previous frame, -1 if none; dynamic (same size): the filter's label. Sizes that do not
  // fit are ignored (no votes). Locks the map mutex. Returns the number of points flagged now.
  int Vote(Map& map, const std::vector<std::shared_ptr<MapPoint>>& previous_points,
           const std::vector<int>& previous_match, const std::vector<uint8_t>& dynamic);

  const std::vector<MapPointLabel>& flagged() const { return flagged_; }
  const DynamicPointOptions& options() const { return options_; }

 private:
  DynamicPointOptions options_;
  std::vector<MapPointLabel> flagged_;
};

// One observation of a point in the map (the one of its earliest active keyframe); the caller
// holds the map mutex.
MapPointLabel LabelOf(const Map& map, const MapPoint& point);

}  // namespace dygslam
