#include "core/slam/map/place_recognition.h"

#include <algorithm>
#include <unordered_map>

namespace dygslam {
namespace {

std::vector<std::shared_ptr<KeyFrame>> GroupCandidates(const Map& map,
                                                       const std::vector<PlaceCandidate>& found,
                                                       const PlaceRecognitionOptions& options) {
  std::unordered_map<int64_t, double> score;
  for (const PlaceCandidate& c : found) score[c.keyframe_id] = c.score;
  struct Group {
    double accumulated = 0, best_score = 0;
    std::shared_ptr<KeyFrame> best;
  };
  std::vector<Group> groups;
  double best_accumulated = 0;
  for (const PlaceCandidate& c : found) {
    auto kf = map.GetKeyFrame(c.keyframe_id);
    if (!kf || kf->bad) continue;
    Group g{c.score, c.score, kf};
    for (int64_t n : kf->BestCovisibles(options.group_neighbors)) {
      auto it = score.find(n);
      if (it == score.end()) continue;
      g.accumulated += it->second;
      if (it->second > g.best_score) {
        auto other = map.GetKeyFrame(n);
        if (!other || other->bad) continue;
        g.best_score = it->second;
        g.best = other;
      }
    }
    best_accumulated = std::max(best_accumulated, g.accumulated);
    groups.push_back(std::move(g));
  }
  std::stable_sort(groups.begin(), groups.end(),
                   [](const Group& a, const Group& b) { return a.accumulated > b.accumulated; });
  std::vector<std::shared_ptr<KeyFrame>> out;
  for (const Group& g : groups) {
    if (g.accumulated < options.group_score_ratio * best_accumulated) break;
    if (std::find(out.begin(), out.end(), g.best) != out.end()) continue;
    out.push_back(g.best);
    if (static_cast<int>(out.size()) >= options.max_candidates) break;
  }
  return out;
}

}  // namespace

std::vector<std::shared_ptr<KeyFrame>> RelocalizationCandidates(
    const Map& map, const KeyFrameDatabase& database, const BowVector& bow,
    const PlaceRecognitionOptions& options) {
  PlaceQueryOptions q;
  q.min_common_words_ratio = options.min_common_words_ratio;
  q.max_results = 1 << 30;
  const auto found =
      database.Query(bow, q, [&](int64_t id) { return map.GetKeyFrame(id) == nullptr; });
  return GroupCandidates(map, found, options);
}

std::vector<std::shared_ptr<KeyFrame>> LoopCandidates(const Map& map,
                                                      const KeyFrameDatabase& database,
                                                      const KeyFrame& kf, double min_score,
                                                      const std::function<bool(int64_t)>& exclude,
                                                      const PlaceRecognitionOptions& options) {
  PlaceQueryOptions q;
  q.min_common_words_ratio = options.min_common_words_ratio;
  q.min_score = min_score;
  q.max_results = 1 << 30;
  const auto found = database.Query(kf.bow_vector, q, [&](int64_t id) {
    return id == kf.id || map.GetKeyFrame(id) == nullptr || (exclude && exclude(id));
  });
  return GroupCandidates(map, found, options);
}

std::vector<PlaceCandidate> QueryLoopCandidates(const KeyFrameDatabase& database,
                                                const KeyFrame& kf, double min_score,
                                                const std::function<bool(int64_t)>& exclude,
                                                const PlaceRecognitionOptions& options) {
  PlaceQueryOptions q;
  q.min_common_words_ratio = options.min_common_words_ratio;
  q.min_score = min_score;
  q.max_results = 1 << 30;
  return database.Query(kf.bow_vector, q,
                        [&](int64_t id) { return id == kf.id || (exclude && exclude(id)); });
}

std::vector<std::shared_ptr<KeyFrame>> GroupPlaceCandidates(
    const Map& map, const std::vector<PlaceCandidate>& found,
    const PlaceRecognitionOptions& options) {
  return GroupCandidates(map, found, options);
}

}  // namespace dygslam
