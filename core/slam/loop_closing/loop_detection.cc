#include "core/slam/loop_closing/loop_detection.h"

#include <algorithm>
#include <sstream>
#include <utility>

#include "core/base/log.h"

namespace dygslam {

// Culled keyframes count at their resolved pose: skipping them would cut the corners of the path
// (on the there-and-back sequence, 1.39 m instead of ~1.9 m at the return).
std::map<int64_t, double> KeyFramePathLengths(const Map& map, int64_t from, int64_t to) {
  std::vector<std::pair<int64_t, Eigen::Vector3d>> centers;
  for (int64_t id = std::max<int64_t>(from, 0); id <= to; ++id) {
    if (const auto active = map.keyframes().find(id); active != map.keyframes().end())
      centers.emplace_back(id, active->second->CameraCenter());
    else if (map.IsCulled(id))
      centers.emplace_back(id, map.ResolvedPose(id).Inverse().translation);
  }
  std::map<int64_t, double> lengths;
  double length = 0;
  for (size_t k = centers.size(); k-- > 0;) {
    if (k + 1 < centers.size()) length += (centers[k + 1].second - centers[k].second).norm();
    lengths[centers[k].first] = length;
  }
  return lengths;
}

double KeyFramePathLength(const Map& map, int64_t from, int64_t to) {
  const auto lengths = KeyFramePathLengths(map, from, to);
  const auto it = lengths.find(from);
  return it == lengths.end() ? 0.0 : it->second;
}

LoopDetector::LoopDetector(std::shared_ptr<Map> map, std::shared_ptr<KeyFrameDatabase> database,
                           const LoopClosingOptions& options)
    : map_(std::move(map)), database_(std::move(database)), options_(options) {}

void LoopDetector::LoopClosedAt(int64_t kf_id) {
  last_loop_kf_id_ = kf_id;
  consistent_groups_.clear();
}

bool LoopDetector::ReadQueryContext(const KeyFrame& kf, QueryContext* context) const {
  std::lock_guard<std::mutex> lock(map_->mutex());
  if (kf.bad || kf.bow_vector.empty()) return false;
  if (last_loop_kf_id_ >= 0 && kf.id < last_loop_kf_id_ + options_.min_keyframe_gap) return false;
  if (static_cast<int>(map_->NumKeyFrames()) <= options_.min_keyframe_gap) return false;
  for (int64_t id : kf.ordered_connections) {
    auto n = map_->GetKeyFrame(id);
    if (n && !n->bad && !n->bow_vector.empty()) context->covisibles.push_back(n);
  }
  for (const auto& [id, k] : map_->keyframes()) context->active.insert(id);
  int64_t oldest = kf.id;
  for (const auto& [id, w] : kf.connection_weights) {
    context->connected.insert(id);
    if (options_.revisit_min_path_m > 0 && id <= kf.id - options_.min_keyframe_gap)
      oldest = std::min(oldest, id);
  }
  if (oldest < kf.id) {
    const auto lengths = KeyFramePathLengths(*map_, oldest, kf.id);
    for (int64_t id : context->connected) {
      const auto it = lengths.find(id);
      if (id <= kf.id - options_.min_keyframe_gap && it != lengths.end())
        context->revisit_path[id] = it->second;
    }
  }
  return true;
}

std::vector<std::shared_ptr<KeyFrame>> LoopDetector::Detect(const std::shared_ptr<KeyFrame>& kf) {
  // The keyframes' BoW vectors are immutable: only the filter's inputs need the map lock.
  QueryContext context;
  if (!ReadQueryContext(*kf, &context)) return {};
  // The keyframe's worst covisible neighbour sets the bar.
  double min_score = 1.0;
  for (const auto& n : context.covisibles)
    min_score = std::min(min_score, Vocabulary::Score(kf->bow_vector, n->bow_vector));
  if (context.covisibles.empty()) min_score = 0;
  const auto found = QueryLoopCandidates(
      *database_, *kf, min_score,
      [&](int64_t id) {
        if (context.active.count(id) == 0) return true;            // culled
        if (id > kf->id - options_.min_keyframe_gap) return true;  // recent
        if (context.connected.count(id) == 0) return false;
        // Covisible: ORB-SLAM2 excludes these, as covisibility normally means the local window
        // (already joined by local BA, nothing to correct). An old keyframe that became
        // covisible again after a long way round is the place revisited, tracked without losing
        // the map (there and back): it stays a candidate, so the revisit is closed as a loop.
        const auto path = context.revisit_path.find(id);
        return options_.revisit_min_path_m <= 0 || path == context.revisit_path.end() ||
               path->second < options_.revisit_min_path_m;
      },
      options_.place);
  std::lock_guard<std::mutex> lock(map_->mutex());
  const auto candidates = GroupPlaceCandidates(*map_, found, options_.place);
  if (GetLogLevel() <= LogLevel::kDebug) {
    std::ostringstream line;
    line << "loop detection: keyframe " << kf->id << " (frame " << kf->frame_id << "), bar "
         << min_score << ", " << found.size() << " found, " << candidates.size()
         << " after grouping; old covisible:";
    for (const auto& [id, path] : context.revisit_path) line << " " << id << " (" << path << " m)";
    line << "; grouped:";
    for (const auto& c : candidates) line << " " << c->id << " (frame " << c->frame_id << ")";
    LOG_DEBUG << line.str();
  }
  return KeepConsistent(candidates);
}

// A candidate group (the candidate and its covisible keyframes) that overlaps a group of the
// previous keyframe inherits its count + 1; enough consecutive overlaps make the candidate a
// loop. The caller holds the map lock (the candidates' connections are read).
std::vector<std::shared_ptr<KeyFrame>> LoopDetector::KeepConsistent(
    const std::vector<std::shared_ptr<KeyFrame>>& candidates) {
  if (candidates.empty()) {
    consistent_groups_.clear();
    return {};
  }
  std::vector<ConsistentGroup> current;
  std::vector<uint8_t> used(consistent_groups_.size(), 0);
  std::vector<std::shared_ptr<KeyFrame>> enough;
  for (const auto& c : candidates) {
    std::set<int64_t> group = {c->id};
    for (const auto& [id, w] : c->connection_weights) group.insert(id);
    bool consistent_any = false, added = false;
    for (size_t g = 0; g < consistent_groups_.size(); ++g) {
      const auto& previous = consistent_groups_[g].keyframes;
      const bool overlap = std::any_of(group.begin(), group.end(),
                                       [&](int64_t id) { return previous.count(id) > 0; });
      if (!overlap) continue;
      consistent_any = true;
      const int consistency = consistent_groups_[g].consistency + 1;
      if (!used[g]) {
        current.push_back({group, consistency});
        used[g] = 1;
      }
      if (consistency >= options_.consistency && !added) {
        enough.push_back(c);
        added = true;
      }
    }
    if (!consistent_any) current.push_back({group, 0});
  }
  consistent_groups_ = std::move(current);
  return enough;
}

}  // namespace dygslam
