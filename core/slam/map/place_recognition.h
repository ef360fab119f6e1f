// Keyframe candidates from the inverted index, ORB-SLAM2's way: keyframes sharing many words with
// the query are scored (L1), each score is accumulated over the candidate's covisible neighbours
// that are candidates too (a place is a group of keyframes, not one), and the best keyframe of
// every group scoring >= 0.75 of the best group is returned. Cost grows with the keyframes that
// share words with the query, not with the map. The caller holds Map::mutex().
#pragma once

#include <functional>
#include <memory>
#include <vector>

#include "core/place/keyframe_database.h"
#include "core/slam/map/map.h"

namespace dygslam {

struct PlaceRecognitionOptions {
  double min_common_words_ratio = 0.8;  // of the best candidate's shared words
  double group_score_ratio = 0.75;      // of the best group's accumulated score
  int group_neighbors = 10;             // covisible neighbours in a group
  int max_candidates = 10;
  void Check() const {
    DYGSLAM_CHECK_OPTION(min_common_words_ratio >= 0 && min_common_words_ratio <= 1,
                         "PlaceRecognition.min_common_words_ratio");
    DYGSLAM_CHECK_OPTION(group_score_ratio >= 0 && group_score_ratio <= 1,
                         "PlaceRecognition.group_score_ratio");
    DYGSLAM_CHECK_OPTION(group_neighbors >= 0, "PlaceRecognition.group_neighbors");
    DYGSLAM_CHECK_OPTION(max_candidates >= 1, "PlaceRecognition.max_candidates");
  }
};

// Candidates for relocalizing a frame with BoW vector `bow`, best group first.
std::vector<std::shared_ptr<KeyFrame>> RelocalizationCandidates(
    const Map& map, const KeyFrameDatabase& database, const BowVector& bow,
    const PlaceRecognitionOptions& options);

// Loop candidates for keyframe `kf`: keyframes scoring at least `min_score`, excluding `kf` and
// those `exclude` rejects (its covisible neighbours, recent keyframes).
std::vector<std::shared_ptr<KeyFrame>> LoopCandidates(const Map& map,
                                                      const KeyFrameDatabase& database,
                                                      const KeyFrame& kf, double min_score,
                                                      const std::function<bool(int64_t)>& exclude,
                                                      const PlaceRecognitionOptions& options);

// LoopCandidates in two steps, for a caller that queries the index without the map lock:
// the query (reads only the index and the keyframe's immutable BoW vector; `exclude` must not
// touch the map unless the caller holds its lock), then the grouping (the caller holds
// Map::mutex()).
std::vector<PlaceCandidate> QueryLoopCandidates(const KeyFrameDatabase& database,
                                                const KeyFrame& kf, double min_score,
                                                const std::function<bool(int64_t)>& exclude,
                                                const PlaceRecognitionOptions& options);
std::vector<std::shared_ptr<KeyFrame>> GroupPlaceCandidates(
    const Map& map, const std::vector<PlaceCandidate>& found,
    const PlaceRecognitionOptions& options);

}  // namespace dygslam
