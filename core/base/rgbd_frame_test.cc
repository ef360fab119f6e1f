#include "core/base/rgbd_frame.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/base/error.h"

namespace dygslam {
namespace {

RgbdFrame Frame(int width, int height) {
  RgbdFrame frame;
  frame.rgb = cv::Mat(height, width, CV_8UC3, cv::Scalar(10, 20, 30));
  frame.depth = cv::Mat(height, width, CV_16UC1, cv::Scalar(5000));
  return frame;
}

// Asserts that `fn` throws InputError whose message contains `part`.
template <class Fn>
void ExpectErrorNaming(Fn fn, const std::string& part) {
  try {
    fn();
    ADD_FAILURE() << "no error; expected one naming '" << part << "'";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
  }
}

TEST(RgbdFrame, RawDepthIsDividedByItsScale) {
  RgbdFrame frame = Frame(4, 3);
  frame.depth.at<uint16_t>(1, 2) = 12345;
  frame.depth.at<uint16_t>(2, 0) = 0;  // no measurement stays 0
  cv::Mat metres = frame.DepthInMetres();
  ASSERT_EQ(metres.type(), CV_32FC1);
  EXPECT_EQ(metres.at<float>(0, 0), 1.0f);
  EXPECT_FLOAT_EQ(metres.at<float>(1, 2), 12345 / 5000.0f);
  EXPECT_EQ(metres.at<float>(2, 0), 0.0f);
  frame.depth_scale = 1000;  // ROS 2 drivers: millimetres
  EXPECT_EQ(frame.DepthInMetres().at<float>(0, 0), 5.0f);
}

TEST(RgbdFrame, MetresAreSharedNotConverted) {
  RgbdFrame frame = Frame(4, 3);
  frame.depth = cv::Mat(3, 4, CV_32FC1, cv::Scalar(1.25));
  frame.depth_scale = 0;  // not used for metres
  const cv::Mat metres = frame.DepthInMetres();
  EXPECT_EQ(metres.data, frame.depth.data);
  EXPECT_NO_THROW(CheckRgbdFrame(frame, 4, 3));
}

TEST(RgbdFrame, CheckNamesTheImageAndWhatIsWrong) {
  EXPECT_NO_THROW(CheckRgbdFrame(Frame(4, 3), 4, 3));
  ExpectErrorNaming([] { CheckRgbdFrame(Frame(4, 3), 5, 3); }, "rgb image: size 4x3");
  RgbdFrame frame = Frame(4, 3);
  frame.rgb = cv::Mat(3, 4, CV_16UC3);
  ExpectErrorNaming([&] { CheckRgbdFrame(frame, 4, 3); }, "rgb image");
  frame = Frame(4, 3);
  frame.depth = cv::Mat(3, 4, CV_8UC1);
  ExpectErrorNaming([&] { CheckRgbdFrame(frame, 4, 3); }, "depth image");
  ExpectErrorNaming([&] { frame.DepthInMetres(); }, "depth image");
  frame = Frame(4, 3);
  frame.depth = cv::Mat(2, 4, CV_16UC1);
  ExpectErrorNaming([&] { CheckRgbdFrame(frame, 4, 3); }, "depth image: size");
  for (double bad : {0.0, -5000.0, std::nan("")}) {
    frame = Frame(4, 3);
    frame.depth_scale = bad;
    ExpectErrorNaming([&] { CheckRgbdFrame(frame, 4, 3); }, "depth_scale");
    ExpectErrorNaming([&] { frame.DepthInMetres(); }, "depth_scale");
  }
  frame = Frame(4, 3);
  frame.mask = cv::Mat(3, 4, CV_32FC1);
  ExpectErrorNaming([&] { CheckRgbdFrame(frame, 4, 3); }, "mask: expected CV_8UC1 4x3");
}

}  // namespace
}  // namespace dygslam
