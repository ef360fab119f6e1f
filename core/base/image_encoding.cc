#include "core/base/image_encoding.h"

#include <cstring>
#include <stdexcept>

namespace dygslam {

std::string ImageEncodingOf(int cv_type, const std::string& what) {
  switch (cv_type) {
    case CV_8UC3:
      return "bgr8";
    case CV_8UC1:
      return "mono8";
    case CV_16UC1:
      return "16UC1";
    case CV_32FC1:
      return "32FC1";
    default:
      throw std::invalid_argument(what + ": unsupported cv::Mat type " + std::to_string(cv_type));
  }
}

std::vector<uint8_t> PackedImageRows(const cv::Mat& image) {
  const size_t row_bytes = image.cols * image.elemSize();
  std::vector<uint8_t> data(row_bytes * image.rows);
  if (image.isContinuous()) {
    if (!data.empty()) std::memcpy(data.data(), image.data, data.size());
  } else {
    for (int r = 0; r < image.rows; ++r) {
      std::memcpy(data.data() + r * row_bytes, image.ptr(r), row_bytes);
    }
  }
  return data;
}

}  // namespace dygslam
