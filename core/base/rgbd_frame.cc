#include "core/base/rgbd_frame.h"

#include <cmath>
#include <string>

#include "core/base/error.h"

namespace dygslam {
namespace {

std::string SizeText(const cv::Mat& image) {
  return std::to_string(image.cols) + "x" + std::to_string(image.rows);
}

bool UsableScale(double scale) { return std::isfinite(scale) && scale > 0; }

}  // namespace

cv::Mat RgbdFrame::DepthInMetres() const {
  if (depth.type() == CV_32FC1) return depth;
  if (depth.type() != CV_16UC1) throw InputError("depth image: expected CV_16UC1 or CV_32FC1");
  if (!UsableScale(depth_scale)) {
    throw InputError("depth image: depth_scale must be a finite number > 0, got " +
                     std::to_string(depth_scale));
  }
  cv::Mat metres;
  depth.convertTo(metres, CV_32F, 1.0 / depth_scale);
  return metres;
}

void CheckRgbdFrame(const RgbdFrame& frame, int width, int height) {
  const cv::Mat& rgb = frame.rgb;
  if (rgb.empty() || (rgb.type() != CV_8UC3 && rgb.type() != CV_8UC1))
    throw InputError("rgb image: expected CV_8UC3 (or CV_8UC1), got type " +
                     std::to_string(rgb.type()));
  if (rgb.cols != width || rgb.rows != height)
    throw InputError("rgb image: size " + SizeText(rgb) + " does not match Camera.width/height " +
                     std::to_string(width) + "x" + std::to_string(height));
  const cv::Mat& depth = frame.depth;
  if (depth.empty() || (depth.type() != CV_16UC1 && depth.type() != CV_32FC1))
    throw InputError("depth image: expected CV_16UC1 or CV_32FC1");
  if (depth.size() != rgb.size()) throw InputError("depth image: size differs from the rgb image");
  if (depth.type() == CV_16UC1 && !UsableScale(frame.depth_scale)) {
    throw InputError("depth image: depth_scale must be a finite number > 0, got " +
                     std::to_string(frame.depth_scale));
  }
  const cv::Mat& mask = frame.mask;
  if (!mask.empty() && (mask.type() != CV_8UC1 || mask.size() != rgb.size()))
    throw InputError("mask: expected CV_8UC1 " + SizeText(rgb) + ", got type " +
                     std::to_string(mask.type()) + " " + SizeText(mask));
}

}  // namespace dygslam
