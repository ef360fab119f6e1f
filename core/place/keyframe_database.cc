#include "core/place/keyframe_database.h"

#include <algorithm>

namespace dygslam {

void KeyFrameDatabase::Add(int64_t keyframe_id, const BowVector& bow) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (vectors_.count(keyframe_id)) return;
  vectors_[keyframe_id] = bow;
  for (const auto& [word, weight] : bow) {
    auto& list = inverted_[word];
    list.insert(std::upper_bound(list.begin(), list.end(), keyframe_id), keyframe_id);
  }
}

void KeyFrameDatabase::Erase(int64_t keyframe_id) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = vectors_.find(keyframe_id);
  if (it == vectors_.end()) return;
  for (const auto& [word, weight] : it->second) {
    auto list = inverted_.find(word);
    if (list == inverted_.end()) continue;
    auto pos = std::lower_bound(list->second.begin(), list->second.end(), keyframe_id);
    if (pos != list->second.end() && *pos == keyframe_id) list->second.erase(pos);
    if (list->second.empty()) inverted_.erase(list);
  }
  vectors_.erase(it);
}

void KeyFrameDatabase::Clear() {
  std::lock_guard<std::mutex> lock(mutex_);
  inverted_.clear();
  vectors_.clear();
}

size_t KeyFrameDatabase::size() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return vectors_.size();
}

std::vector<PlaceCandidate> KeyFrameDatabase::Query(
    const BowVector& bow, const PlaceQueryOptions& options,
    const std::function<bool(int64_t)>& exclude) const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::unordered_map<int64_t, int> common;
  for (const auto& [word, weight] : bow) {
    auto list = inverted_.find(word);
    if (list == inverted_.end()) continue;
    for (int64_t id : list->second) common[id]++;
  }
  int max_common = 0;
  std::vector<std::pair<int64_t, int>> kept;
  for (const auto& [id, n] : common) {
    if (exclude && exclude(id)) continue;
    kept.push_back({id, n});
    max_common = std::max(max_common, n);
  }
  const int min_common = std::max(options.min_common_words,
                                  static_cast<int>(options.min_common_words_ratio * max_common));
  std::vector<PlaceCandidate> out;
  for (const auto& [id, n] : kept) {
    if (n < min_common) continue;
    const double s = Vocabulary::Score(bow, vectors_.at(id));
    if (s < options.min_score) continue;
    out.push_back({id, n, s});
  }
  std::sort(out.begin(), out.end(), [](const PlaceCandidate& a, const PlaceCandidate& b) {
    return a.score != b.score ? a.score > b.score : a.keyframe_id < b.keyframe_id;
  });
  if (static_cast<int>(out.size()) > options.max_results) out.resize(options.max_results);
  return out;
}

double KeyFrameDatabase::ScoreAgainst(const BowVector& bow, int64_t keyframe_id) const {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = vectors_.find(keyframe_id);
  return it == vectors_.end() ? 0.0 : Vocabulary::Score(bow, it->second);
}

}  // namespace dygslam
