// Loop detection, the first step of loop closing: loop candidates for a keyframe from the BoW
// index (scoring at least as well as the keyframe's worst covisible neighbour, not covisible
// unless revisited after a long way round, not recent), kept only when consistent over
// `LoopClosing.consistency` consecutive keyframes (candidate groups overlapping).
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <set>
#include <vector>

#include "core/place/keyframe_database.h"
#include "core/slam/loop_closing/loop_closing_options.h"
#include "core/slam/map/map.h"

namespace dygslam {

// Keyframe path from keyframe `from` to keyframe `to`: the summed distances between the centres
// of the keyframes made in between, in creation order, culled keyframes included at their
// resolved pose (0 if `from` was never made). Locks nothing: the caller holds Map::mutex().
double KeyFramePathLength(const Map& map, int64_t from, int64_t to);

// The same path length from every keyframe id in [from, to] to `to` (ids that were never made
// are absent). The caller holds Map::mutex().
std::map<int64_t, double> KeyFramePathLengths(const Map& map, int64_t from, int64_t to);

// Detection state of one loop closing thread: the consistency groups of the last keyframe and
// the last loop closed. Not thread-safe: one thread detects and reports closed loops.
class LoopDetector {
 public:
  LoopDetector(std::shared_ptr<Map> map, std::shared_ptr<KeyFrameDatabase> database,
               const LoopClosingOptions& options);

  // The consistent loop candidates of `kf` (empty: none yet). Takes the map lock to read what
  // the index query's filter needs; the query itself runs without it.
  std::vector<std::shared_ptr<KeyFrame>> Detect(const std::shared_ptr<KeyFrame>& kf);
  // A loop was closed at keyframe `kf_id`: no candidates for the next `min_keyframe_gap`
  // keyframes, and consistency starts again.
  void LoopClosedAt(int64_t kf_id);

 private:
  // What the index query's filter needs, read under the map lock.
  struct QueryContext {
    std::vector<std::shared_ptr<KeyFrame>> covisibles;
    std::set<int64_t> active, connected;
    std::map<int64_t, double> revisit_path;  // keyframe path from an old covisible one to kf
  };
  bool ReadQueryContext(const KeyFrame& kf, QueryContext* context) const;
  std::vector<std::shared_ptr<KeyFrame>> KeepConsistent(
      const std::vector<std::shared_ptr<KeyFrame>>& candidates);

  struct ConsistentGroup {
    std::set<int64_t> keyframes;
    int consistency = 0;
  };
  std::shared_ptr<Map> map_;
  std::shared_ptr<KeyFrameDatabase> database_;
  LoopClosingOptions options_;
  std::vector<ConsistentGroup> consistent_groups_;
  int64_t last_loop_kf_id_ = -1;
};

}  // namespace dygslam
