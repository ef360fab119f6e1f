#include "core/slam/map/dynamic_points.h"

#include <mutex>

#include "core/base/error.h"

namespace dygslam {

void DynamicPointOptions::Check() const {
  DYGSLAM_CHECK_OPTION(min_votes >= 1 && min_votes <= 1000, "DynamicPoints.min_votes");
  DYGSLAM_CHECK_OPTION(min_dynamic_fraction >= 0 && min_dynamic_fraction <= 1,
                       "DynamicPoints.min_dynamic_fraction");
}

DynamicPointVoter::DynamicPointVoter(const DynamicPointOptions& options) : options_(options) {
  options_.Check();
}

MapPointLabel LabelOf(const Map& map, const MapPoint& point) {
  MapPointLabel label;
  label.point_id = point.id;
  label.is_dynamic = point.is_dynamic;
  for (const auto& [kf_id, idx] : point.observations) {  // ordered by keyframe id
    const std::shared_ptr<KeyFrame> kf = map.GetKeyFrame(kf_id);
    if (!kf || idx < 0 || idx >= static_cast<int>(kf->keypoints.size())) continue;
    label.frame_id = kf->frame_id;
    label.pixel = kf->keypoints[idx].pt;
    break;
  }
  return label;
}

int DynamicPointVoter::Vote(Map& map, const std::vector<std::shared_ptr<MapPoint>>& previous_points,
                            const std::vector<int>& previous_match,
                            const std::vector<uint8_t>& dynamic) {
  if (!options_.enabled || previous_points.empty() || previous_match.size() != dynamic.size())
    return 0;
  const int num_previous = static_cast<int>(previous_points.size());
  int flagged = 0;
  std::lock_guard<std::mutex> lock(map.mutex());
  for (size_t i = 0; i < previous_match.size(); ++i) {
    const int j = previous_match[i];
    if (j < 0 || j >= num_previous) continue;
    std::shared_ptr<MapPoint> point = previous_points[j];
    int guard = 0;
    while (point && point->replaced_by && guard++ < 100) point = point->replaced_by;
    if (!point || point->bad) continue;
    if (!dynamic[i]) {
      ++point->static_votes;
      continue;
    }
    ++point->dynamic_votes;
    const int votes = point->dynamic_votes + point->static_votes;
    if (point->dynamic_votes < options_.min_votes ||
        point->dynamic_votes < options_.min_dynamic_fraction * votes)
      continue;
    point->is_dynamic = true;
    flagged_.push_back(LabelOf(map, *point));
    map.SetBad(point);
    ++flagged;
  }
  return flagged;
}

}  // namespace dygslam
