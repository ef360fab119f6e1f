#include "core/base/image_encoding.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

namespace dygslam {
namespace {

TEST(ImageEncoding, NamesThePipelineTypesAndRefusesOthers) {
  EXPECT_EQ(ImageEncodingOf(CV_8UC3, "x"), "bgr8");
  EXPECT_EQ(ImageEncodingOf(CV_8UC1, "x"), "mono8");
  EXPECT_EQ(ImageEncodingOf(CV_16UC1, "x"), "16UC1");
  EXPECT_EQ(ImageEncodingOf(CV_32FC1, "x"), "32FC1");
  try {
    ImageEncodingOf(CV_64FC1, "ImageToMsg");
    FAIL() << "CV_64FC1 accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()),
              "ImageToMsg: unsupported cv::Mat type " + std::to_string(CV_64FC1));
  }
}

TEST(ImageEncoding, PacksTheRowsOfAView) {
  cv::Mat image(4, 6, CV_16UC1);
  for (int r = 0; r < image.rows; ++r) {
    for (int c = 0; c < image.cols; ++c)
      image.at<uint16_t>(r, c) = static_cast<uint16_t>(r * 100 + c);
  }
  const cv::Mat view = image(cv::Rect(1, 1, 3, 2));  // not continuous
  ASSERT_FALSE(view.isContinuous());
  const std::vector<uint8_t> packed = PackedImageRows(view);
  ASSERT_EQ(packed.size(), 3u * 2u * 2u);
  const auto* values = reinterpret_cast<const uint16_t*>(packed.data());
  EXPECT_EQ(values[0], 101);
  EXPECT_EQ(values[2], 103);
  EXPECT_EQ(values[3], 201);
  EXPECT_EQ(values[5], 203);
  EXPECT_EQ(PackedImageRows(image).size(), 4u * 6u * 2u);
}

}  // namespace
}  // namespace dygslam
