#include "core/slam/feature/frame_preparation.h"

#include <algorithm>
#include <opencv2/imgproc.hpp>

namespace dygslam {
namespace {

// Corners of `kept` in 8-pixel cells, for the duplicate test of the top-up.
class CornerGrid {
 public:
  CornerGrid(const cv::Size& image, const std::vector<cv::KeyPoint>& keypoints)
      : cols_(image.width / kCell + 1), rows_(image.height / kCell + 1), cells_(cols_ * rows_) {
    for (size_t i = 0; i < keypoints.size(); ++i) cells_[CellOf(keypoints[i].pt)].push_back(i);
  }

  // A corner of `keypoints` (the ones the grid was made of) on the same level within 2 px.
  bool HasNear(const cv::KeyPoint& kp, const std::vector<cv::KeyPoint>& keypoints) const {
    const int cx = std::clamp(int(kp.pt.x) / kCell, 0, cols_ - 1),
              cy = std::clamp(int(kp.pt.y) / kCell, 0, rows_ - 1);
    for (int y = std::max(0, cy - 1); y <= std::min(rows_ - 1, cy + 1); ++y) {
      for (int x = std::max(0, cx - 1); x <= std::min(cols_ - 1, cx + 1); ++x) {
        for (size_t i : cells_[y * cols_ + x]) {
          const cv::KeyPoint& other = keypoints[i];
          if (other.octave == kp.octave && cv::norm(other.pt - kp.pt) < 2.0) return true;
        }
      }
    }
    return false;
  }

 private:
  static constexpr int kCell = 8;
  int CellOf(const cv::Point2f& p) const {
    return std::clamp(int(p.y) / kCell, 0, rows_ - 1) * cols_ +
           std::clamp(int(p.x) / kCell, 0, cols_ - 1);
  }
  int cols_, rows_;
  std::vector<std::vector<size_t>> cells_;
};

}  // namespace

cv::Mat GrayImage(const cv::Mat& rgb) {
  if (rgb.channels() != 3) return rgb;
  cv::Mat gray;
  cv::cvtColor(rgb, gray, cv::COLOR_BGR2GRAY);
  return gray;
}

void TopUpFeatures(const OrbExtractor& extractor, const cv::Mat& gray, const cv::Mat& mask,
                   const std::vector<cv::Rect>& excluded, int budget, OrbExtractionCache* cache,
                   OrbFeatures* kept) {
  const int shortfall = budget - static_cast<int>(kept->keypoints.size());
  if (shortfall <= 0) return;
  cv::Mat excluded_mask = mask.empty() ? cv::Mat::zeros(gray.size(), CV_8UC1) : mask.clone();
  const cv::Rect image(0, 0, gray.cols, gray.rows);
  for (const cv::Rect& r : excluded) excluded_mask(r & image).setTo(255);
  // Pyramid and corners reused from the first extraction; corners the first extraction kept are
  // dropped before they are described.
  const std::vector<cv::KeyPoint>& original = kept->keypoints;  // appended to after Extract
  const CornerGrid grid(gray.size(), original);
  const OrbFeatures extra =
      extractor.Extract(gray, excluded_mask, shortfall, cache,
                        [&](const cv::KeyPoint& kp) { return grid.HasNear(kp, original); });
  kept->keypoints.insert(kept->keypoints.end(), extra.keypoints.begin(), extra.keypoints.end());
  kept->descriptors.insert(kept->descriptors.end(), extra.descriptors.begin(),
                           extra.descriptors.end());
}

}  // namespace dygslam
