// Loop verification, the second step of loop closing: for each consistent candidate, BoW matches
// between the map points of the keyframe and the candidate, an SE3 (metric depth: no scale) by
// RANSAC on 3-point Horn/Umeyama solutions scored by reprojection in both keyframes, refined on
// the inliers, then a guided projection search of the candidate's neighbourhood from the
// corrected pose and a pose-only refinement on every match. Enough support and a correction
// within the drift budget accept the loop.
//
// The checks work on a copy of the map state they need (poses and map points of the keyframe and
// its candidates), taken under a short map lock; matching, RANSAC, guided search and refinement
// then run without the lock, so tracking and local mapping are not held up.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "core/slam/loop_closing/loop_closing_options.h"
#include "core/slam/map/map.h"
#include "core/slam/feature/matcher.h"
#include "core/slam/optimize/optimizer.h"

namespace dygslam {

// One geometric verification of a loop candidate (RANSAC reached), for logs and calibration.
struct LoopVerification {
  int64_t frame_id = -1, loop_frame_id = -1;
  int bow_pairs = 0, inliers = 0, projected = 0;  // projected: 0 if not reached
  double correction_m = 0, correction_deg = 0;    // how far the loop transform moves the camera
  double path_m = 0;                              // keyframe path since the loop keyframe
  double allowed_m = 0, allowed_deg = 0;          // the drift budget over that path
  const char* verdict = "";                       // "accepted" or the failed check
};

// What the checks of one keyframe's candidates found, candidate by candidate: the verifications
// and, by check, how many candidates failed it first.
struct LoopCheckRecord {
  std::vector<LoopVerification> verifications;
  int rejected_bow = 0, rejected_inliers = 0, rejected_ratio = 0, rejected_projection = 0,
      rejected_implausible = 0;
  double locked_ms = 0;  // time spent holding the map lock for the copies
};

// An accepted loop: what the correction needs.
struct LoopMatch {
  std::shared_ptr<KeyFrame> loop_kf;
  Rigid3d cam_from_world;                              // corrected pose of the current keyframe
  std::vector<std::shared_ptr<MapPoint>> matches;      // per feature of the current keyframe
  std::vector<std::shared_ptr<MapPoint>> loop_points;  // the loop keyframe's neighbourhood
  int inliers = 0, projected = 0;
  double correction_m = 0, correction_deg = 0;  // how far the loop moves the current keyframe
  int64_t epoch = -1;  // Map::CorrectionEpoch() of the map state the checks saw
};

class LoopVerifier {
 public:
  LoopVerifier(std::shared_ptr<Map> map, const LoopClosingOptions& options,
               const OptimizerOptions& optimizer, const MatcherOptions& matcher);

  // The first of `candidates` (in order) that passes every check, or none. Takes the map lock
  // only to copy what the checks read; every check is recorded in `record`.
  std::optional<LoopMatch> Verify(const std::shared_ptr<KeyFrame>& kf,
                                  const std::vector<std::shared_ptr<KeyFrame>>& candidates,
                                  LoopCheckRecord* record) const;

 private:
  struct Snapshot;
  bool TakeSnapshot(const std::shared_ptr<KeyFrame>& kf,
                    const std::vector<std::shared_ptr<KeyFrame>>& candidates,
                    Snapshot* snapshot) const;
  void CopyNeighbourhood(size_t candidate, Snapshot* snapshot) const;  // locks the map briefly
  std::optional<LoopMatch> VerifyCandidate(size_t candidate, Snapshot* snapshot, uint64_t* rng,
                                           LoopCheckRecord* record) const;

  std::shared_ptr<Map> map_;
  LoopClosingOptions options_;
  OptimizerOptions optimizer_;
  Matcher matcher_;
};

}  // namespace dygslam
