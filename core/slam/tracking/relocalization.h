// Relocalization of a frame against the map (no pose prior): candidate keyframes, descriptor
// matches to their map points, EPnP-RANSAC, pose optimisation, a projection search for more
// matches, optimisation again. Candidates and matches come from the bag-of-words index when a
// database and vocabulary are given (cost grows with the keyframes that look alike, not with the
// map), else from brute-force matching against every keyframe (the pre-vocabulary behaviour, kept
// as the baseline). The caller holds Map::mutex().
#pragma once

#include <memory>

#include "core/place/keyframe_database.h"
#include "core/slam/tracking/tracking.h"

namespace dygslam {

struct RelocalizationResult {
  bool ok = false;
  std::shared_ptr<KeyFrame> keyframe;  // the candidate that gave the pose
  int candidates = 0;                  // keyframes tried with PnP
  int inliers = 0;
};

// On success frame.cam_from_world / map_points / outlier hold the pose and its inlier matches;
// on failure frame.map_points are cleared and has_pose is false.
RelocalizationResult RelocalizeFrame(Frame& frame, const Map& map, const KeyFrameDatabase* database,
                                     const Vocabulary* vocabulary, const Matcher& matcher,
                                     const TrackingOptions& options);

}  // namespace dygslam
