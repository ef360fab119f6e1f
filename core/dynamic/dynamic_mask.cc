#include "core/dynamic/dynamic_mask.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

namespace dygslam {

void DynamicMaskOptions::Check() const {
  DYGSLAM_CHECK_OPTION(depth_band > 0 && std::isfinite(depth_band), "DynamicMask.depth_band");
  DYGSLAM_CHECK_OPTION(foreground_min_fraction > 0 && foreground_min_fraction <= 1,
                       "DynamicMask.foreground_min_fraction");
  DYGSLAM_CHECK_OPTION(histogram_bin > 0 && std::isfinite(histogram_bin),
                       "DynamicMask.histogram_bin");
  DYGSLAM_CHECK_OPTION(dilation_px >= 0 && dilation_px <= 100, "DynamicMask.dilation_px");
  DYGSLAM_CHECK_OPTION(feature_radius >= 0 && feature_radius <= 200, "DynamicMask.feature_radius");
  DYGSLAM_CHECK_OPTION(box_margin >= 0 && std::isfinite(box_margin), "DynamicMask.box_margin");
}

namespace {

bool ValidDepth(float d) { return std::isfinite(d) && d > 0.f; }

double Median(std::vector<double> v) {
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + mid, v.end());
  return v[mid];
}

// Nearest depth whose band [d, d + band] holds >= min_fraction of the values; NaN if none.
double ForegroundDepth(const std::vector<float>& depths, const DynamicMaskOptions& o) {
  if (depths.empty()) return std::nan("");
  const float max_d = *std::max_element(depths.begin(), depths.end());
  const int bins = static_cast<int>(max_d / o.histogram_bin) + 2;
  std::vector<int> hist(bins, 0);
  for (float d : depths) ++hist[static_cast<int>(d / o.histogram_bin)];
  const int band_bins = std::max(1, static_cast<int>(std::lround(o.depth_band / o.histogram_bin)));
  const double need = o.foreground_min_fraction * depths.size();
  int window = 0;
  for (int b = 0; b < std::min(band_bins, bins); ++b) window += hist[b];
  for (int b = 0; b < bins; ++b) {
    if (window >= need) {
      // Median of the values in the window.
      std::vector<double> in;
      const double lo = b * o.histogram_bin, hi = (b + band_bins) * o.histogram_bin;
      for (float d : depths)
        if (d >= lo && d < hi) in.push_back(d);
      if (!in.empty()) return Median(in);
    }
    window -= hist[b];
    if (b + band_bins < bins) window += hist[b + band_bins];
  }
  return std::nan("");
}

}  // namespace

double BoxObjectDepth(const cv::Mat& depth, const cv::Rect& box, const DynamicMaskOptions& o) {
  if (depth.empty() || depth.type() != CV_32FC1)
    throw InputError("BoxObjectDepth: depth must be CV_32FC1 metres");
  const cv::Rect rect = box & cv::Rect(0, 0, depth.cols, depth.rows);
  std::vector<float> depths;
  depths.reserve(rect.area());
  for (int y = rect.y; y < rect.y + rect.height; ++y) {
    const float* row = depth.ptr<float>(y);
    for (int x = rect.x; x < rect.x + rect.width; ++x)
      if (ValidDepth(row[x])) depths.push_back(row[x]);
  }
  return ForegroundDepth(depths, o);
}

cv::Mat ComputeDynamicMask(const cv::Size& image_size_in, const cv::Mat& depth,
                           const std::vector<Detection>& detections,
                           const std::vector<cv::KeyPoint>& keypoints,
                           const std::vector<uint8_t>& keypoint_dynamic,
                           const DynamicMaskOptions& o) {
  o.Check();
  if (!depth.empty() && depth.type() != CV_32FC1)
    throw InputError("ComputeDynamicMask: depth must be CV_32FC1 metres");
  if (!keypoint_dynamic.empty() && keypoint_dynamic.size() != keypoints.size())
    throw InputError("ComputeDynamicMask: keypoint_dynamic size differs from keypoints");
  const cv::Size size = depth.empty() ? image_size_in : depth.size();
  cv::Mat mask(size, CV_8UC1, cv::Scalar(0));
  const cv::Rect image_rect(0, 0, size.width, size.height);

  std::vector<double> box_depth(detections.size(), std::nan(""));
  std::vector<cv::Rect> rects(detections.size());
  for (size_t b = 0; b < detections.size(); ++b) {
    const cv::Rect2f& bf = detections[b].box;
    const int x0 = static_cast<int>(std::floor(bf.x - o.box_margin));
    const int y0 = static_cast<int>(std::floor(bf.y - o.box_margin));
    const int x1 = static_cast<int>(std::ceil(bf.x + bf.width + o.box_margin));
    const int y1 = static_cast<int>(std::ceil(bf.y + bf.height + o.box_margin));
    const cv::Rect rect = cv::Rect(x0, y0, x1 - x0, y1 - y0) & image_rect;
    rects[b] = rect;
    if (rect.empty()) continue;
    if (depth.empty()) {
      mask(rect).setTo(255);
      continue;
    }
    // Object depth: the box's foreground mode.
    std::vector<float> depths;
    depths.reserve(rect.area());
    for (int y = rect.y; y < rect.y + rect.height; ++y) {
      const float* row = depth.ptr<float>(y);
      for (int x = rect.x; x < rect.x + rect.width; ++x)
        if (ValidDepth(row[x])) depths.push_back(row[x]);
    }
    if (depths.empty()) {
      mask(rect).setTo(255);
      continue;
    }
    const double object = ForegroundDepth(depths, o);
    if (!std::isfinite(object)) {
      mask(rect).setTo(255);
      continue;
    }
    box_depth[b] = object;
    for (int y = rect.y; y < rect.y + rect.height; ++y) {
      const float* row = depth.ptr<float>(y);
      uint8_t* out = mask.ptr<uint8_t>(y);
      for (int x = rect.x; x < rect.x + rect.width; ++x)
        if (!ValidDepth(row[x]) || std::abs(row[x] - object) <= o.depth_band) out[x] = 255;
    }
  }
  if (o.dilation_px > 0) {
    const cv::Mat kernel = cv::getStructuringElement(
        cv::MORPH_ELLIPSE, cv::Size(2 * o.dilation_px + 1, 2 * o.dilation_px + 1));
    cv::dilate(mask, mask, kernel);
  }
  if (o.feature_radius > 0 && !keypoint_dynamic.empty()) {
    for (size_t k = 0; k < keypoints.size(); ++k) {
      if (!keypoint_dynamic[k]) continue;
      const cv::Point p(static_cast<int>(keypoints[k].pt.x), static_cast<int>(keypoints[k].pt.y));
      if (!image_rect.contains(p)) continue;
      bool draw = true;
      if (!depth.empty() && ValidDepth(depth.at<float>(p))) {
        for (size_t b = 0; b < rects.size(); ++b) {
          if (!rects[b].contains(p) || !std::isfinite(box_depth[b])) continue;
          draw = std::abs(depth.at<float>(p) - box_depth[b]) <= o.depth_band;
          break;
        }
      }
      if (draw) cv::circle(mask, p, o.feature_radius, cv::Scalar(255), cv::FILLED);
    }
  }
  return mask;
}

}  // namespace dygslam
