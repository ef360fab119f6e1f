// Inverted index over keyframes (word -> keyframes containing it), to find the keyframes that
// look like an image without scoring every keyframe: only keyframes sharing words are touched,
// so a query costs about (words in the image) x (keyframes per word), not (keyframes).
// Thread-safe (one internal mutex): tracking adds and queries, loop closing queries, local
// mapping's culling erases.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <unordered_map>
#include <vector>

#include "core/place/vocabulary.h"

namespace dygslam {

struct PlaceQueryOptions {
  // Keyframes sharing fewer than this fraction of the best candidate's shared-word count are
  // not scored (ORB-SLAM2 uses 0.8).
  double min_common_words_ratio = 0.8;
  int min_common_words = 1;
  double min_score = 0.0;  // L1 score threshold
  int max_results = 10;
  void Check() const {
    DYGSLAM_CHECK_OPTION(min_common_words_ratio >= 0 && min_common_words_ratio <= 1,
                         "PlaceQuery.min_common_words_ratio");
    DYGSLAM_CHECK_OPTION(max_results >= 1, "PlaceQuery.max_results");
  }
};

struct PlaceCandidate {
  int64_t keyframe_id = -1;
  int common_words = 0;
  double score = 0;
};

class KeyFrameDatabase {
 public:
  void Add(int64_t keyframe_id, const BowVector& bow);
  void Erase(int64_t keyframe_id);
  void Clear();
  size_t size() const;

  // Candidates for `bow`, best score first (ties by id). `exclude` (optional) drops keyframes
  // before scoring (e.g. the query keyframe itself and its covisible neighbours).
  std::vector<PlaceCandidate> Query(const BowVector& bow, const PlaceQueryOptions& options,
                                    const std::function<bool(int64_t)>& exclude = {}) const;
  // Score of `bow` against a stored keyframe (0 when unknown).
  double ScoreAgainst(const BowVector& bow, int64_t keyframe_id) const;

 private:
  mutable std::mutex mutex_;
  std::unordered_map<WordId, std::vector<int64_t>> inverted_;  // word -> keyframes (ascending)
  std::map<int64_t, BowVector> vectors_;                       // keyframe -> its BoW vector
};

}  // namespace dygslam
