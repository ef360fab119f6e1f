#include "core/dynamic/detection_propagation.h"

#include <algorithm>

namespace dygslam {
namespace {
float Median(std::vector<float>* values) {
  const size_t mid = values->size() / 2;
  std::nth_element(values->begin(), values->begin() + mid, values->end());
  return (*values)[mid];
}
}  // namespace

cv::Point2f MedianDisplacementInBox(const cv::Rect2f& box,
                                    const std::vector<cv::KeyPoint>& previous_keypoints,
                                    const std::vector<cv::KeyPoint>& keypoints,
                                    const std::vector<FeatureStatus>& features, int* count) {
  std::vector<float> dx, dy;
  const size_t n = std::min(keypoints.size(), features.size());
  for (size_t i = 0; i < n; ++i) {
    const int j = features[i].prev_match;
    if (j < 0 || j >= static_cast<int>(previous_keypoints.size())) continue;
    if (!box.contains(keypoints[i].pt)) continue;
    dx.push_back(keypoints[i].pt.x - previous_keypoints[j].pt.x);
    dy.push_back(keypoints[i].pt.y - previous_keypoints[j].pt.y);
  }
  *count = static_cast<int>(dx.size());
  if (dx.empty()) return {0.f, 0.f};
  return {Median(&dx), Median(&dy)};
}

BoxPropagator::BoxPropagator(const BoxPropagationOptions& options) : options_(options) {
  options_.Check();
}

void BoxPropagator::SetDetections(const std::vector<Detection>& detections) {
  boxes_ = detections;
  velocities_.assign(boxes_.size(), cv::Point2f(0.f, 0.f));
  has_boxes_ = true;
}

std::vector<Detection> BoxPropagator::Predict() {
  if (options_.shift_boxes) {
    for (size_t b = 0; b < boxes_.size(); ++b) {
      boxes_[b].box.x += velocities_[b].x;
      boxes_[b].box.y += velocities_[b].y;
    }
  }
  return boxes_;
}

void BoxPropagator::Observe(const std::vector<cv::KeyPoint>& previous_keypoints,
                            const std::vector<cv::KeyPoint>& keypoints,
                            const FilterResult& result) {
  if (!options_.shift_boxes) return;
  for (size_t b = 0; b < boxes_.size(); ++b) {
    int count = 0;
    const cv::Point2f v = MedianDisplacementInBox(boxes_[b].box, previous_keypoints, keypoints,
                                                  result.features, &count);
    if (count >= options_.min_matches) velocities_[b] = v;
  }
}

void BoxPropagator::Reset() {
  boxes_.clear();
  velocities_.clear();
  has_boxes_ = false;
}

}  // namespace dygslam
