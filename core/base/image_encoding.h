// Image encodings on the wire (dygslam/rgbd_frame and ROS 2 sensor_msgs/Image use the same names)
// for the cv::Mat types the pipeline sends, and the row copy both message types need.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace dygslam {

// "bgr8" (CV_8UC3), "mono8" (CV_8UC1), "16UC1" (CV_16UC1), "32FC1" (CV_32FC1). Any other type
// throws std::invalid_argument "<what>: unsupported cv::Mat type <type>".
std::string ImageEncodingOf(int cv_type, const std::string& what);

// The pixels of `image` row after row without padding (cols x elemSize bytes a row), continuous
// or not.
std::vector<uint8_t> PackedImageRows(const cv::Mat& image);

}  // namespace dygslam
