// ORB features ORB-SLAM2-style: scale pyramid, FAST with an initial and a fallback threshold per
// grid cell, quadtree distribution per level, intensity-centroid orientation, steered BRIEF.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <opencv2/core.hpp>
#include <vector>

#include "core/base/descriptor.h"
#include "core/base/error.h"

namespace dygslam {

struct OrbExtractorOptions {
  int num_features = 1000;    // ORBextractor.nFeatures
  double scale_factor = 1.2;  // ORBextractor.scaleFactor
  int num_levels = 8;         // ORBextractor.nLevels
  int ini_th_fast = 20;       // ORBextractor.iniThFAST
  int min_th_fast = 7;        // ORBextractor.minThFAST
  void Check() const {
    DYGSLAM_CHECK_OPTION(num_features > 0 && num_features <= 100000, "ORBextractor.nFeatures");
    DYGSLAM_CHECK_OPTION(scale_factor > 1.0 && scale_factor < 4.0, "ORBextractor.scaleFactor");
    DYGSLAM_CHECK_OPTION(num_levels >= 1 && num_levels <= 32, "ORBextractor.nLevels");
    DYGSLAM_CHECK_OPTION(ini_th_fast > 0 && ini_th_fast < 255, "ORBextractor.iniThFAST");
    DYGSLAM_CHECK_OPTION(min_th_fast > 0 && min_th_fast <= ini_th_fast, "ORBextractor.minThFAST");
  }
};

}  // namespace dygslam

namespace dygslam {

struct OrbFeatures {
  // Level-0 pixel coordinates in the (distorted) input image; octave = pyramid level,
  // angle in degrees, size = patch diameter at level 0, response = FAST score.
  std::vector<cv::KeyPoint> keypoints;
  std::vector<Descriptor> descriptors;
  // Same descriptors as an N x 32 CV_8UC1 matrix view (for OpenCV matchers / DDS).
  cv::Mat DescriptorMatrix() const;
};

// What Extract computes per pyramid level before selecting features (level images, FAST
// corners, smoothed images), kept so that a second extraction on the same image with another mask
// and budget (System's top-up outside the detection boxes) costs only the selection and the
// descriptors. Belongs to one image: Extract recomputes it when given another image.
class OrbExtractionCache {
 public:
  bool IsFor(const cv::Mat& gray) const {
    return !levels_.empty() && gray.data == data_ && gray.size() == size_;
  }

 private:
  friend class OrbExtractor;
  const uint8_t* data_ = nullptr;
  cv::Size size_;
  cv::Mat source_;  // keeps the image alive while the cache refers to it
  std::vector<cv::Mat> levels_;
  std::vector<std::vector<cv::KeyPoint>>
      corners_;                   // all FAST corners at min_th_fast, level coordinates
  std::vector<cv::Mat> blurred_;  // computed on first use
};

class OrbExtractor {
 public:
  explicit OrbExtractor(const OrbExtractorOptions& options);

  // gray: CV_8UC1. mask (optional, CV_8UC1): features are not detected where mask != 0.
  // num_features > 0 overrides the options' budget for this call.
  // cache (optional): reused when it holds this image's pyramid, else filled for it.
  // skip (optional): a selected feature for which it returns true (given its level-0 position and
  // its level as `octave`) is dropped before it is described.
  OrbFeatures Extract(const cv::Mat& gray, const cv::Mat& mask = cv::Mat(), int num_features = -1,
                      OrbExtractionCache* cache = nullptr,
                      const std::function<bool(const cv::KeyPoint&)>& skip = nullptr) const;

  const OrbExtractorOptions& options() const { return options_; }
  double scale(int level) const { return scales_[level]; }
  double sigma2(int level) const { return sigma2_[level]; }
  double inv_sigma2(int level) const { return 1.0 / sigma2_[level]; }
  int num_levels() const { return options_.num_levels; }
  const std::vector<double>& scales() const { return scales_; }

  // Pixel pairs of the binary test pattern (fixed, generated from a seed; see .cc).
  static const std::vector<std::array<cv::Point2f, 2>>& Pattern();

 private:
  void DistributeQuadtree(std::vector<cv::KeyPoint>& candidates, const cv::Rect& area, int target,
                          std::vector<cv::KeyPoint>* kept) const;

  OrbExtractorOptions options_;
  std::vector<double> scales_;
  std::vector<double> sigma2_;
  std::vector<int> FeaturesPerLevel(int num_features) const;
  // The pyramid of `gray` and the FAST corners (at the low threshold) of every level, into `cache`.
  void BuildPyramid(const cv::Mat& gray, OrbExtractionCache* cache) const;
  // Level `level`'s corners outside `mask`, spread over the level by the quadtree: per cell, the
  // corners passing the initial threshold where there are any.
  std::vector<cv::KeyPoint> SelectCorners(const OrbExtractionCache& cache, int level,
                                          const cv::Mat& mask, int wanted) const;
  // Orientation by intensity centroid on the unblurred level image.
  void Orient(const cv::Mat& level_img, std::vector<cv::KeyPoint>* keypoints) const;
  // Steered binary tests on the smoothed level image; the keypoints scaled to level 0, appended
  // to `out` with their descriptors.
  void Describe(OrbExtractionCache* cache, int level, std::vector<cv::KeyPoint> keypoints,
                OrbFeatures* out) const;
  std::vector<int> umax_;  // half-width of the circular patch per row
};

}  // namespace dygslam
