#include "core/dynamic/dynamic_mask.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

namespace dygslam {
namespace {

// Wall at 3.5 m, a person (ellipse) at 1.6 m inside the box, a table edge at 1.0 m also in the box.
struct Scene {
  cv::Mat depth = cv::Mat(480, 640, CV_32FC1, cv::Scalar(3.5f));
  cv::Mat person = cv::Mat(480, 640, CV_8UC1, cv::Scalar(0));
  std::vector<Detection> detections;
  Scene() {
    cv::ellipse(person, cv::Point(300, 260), cv::Size(60, 150), 0, 0, 360, cv::Scalar(255),
                cv::FILLED);
    depth.setTo(1.6f, person);
    Detection d;
    d.box = cv::Rect2f(230, 100, 140, 330);
    d.label = "person";
    detections.push_back(d);
  }
  double Coverage(const cv::Mat& mask, const cv::Mat& region) const {
    cv::Mat both;
    cv::bitwise_and(mask, region, both);
    return static_cast<double>(cv::countNonZero(both)) / cv::countNonZero(region);
  }
};

TEST(DynamicMask, BoxRefinedByForegroundDepth) {
  Scene s;
  // The person fills less than half of the box; the wall behind must stay unmasked.
  const cv::Mat mask = ComputeDynamicMask(s.depth.size(), s.depth, s.detections, {}, {});
  ASSERT_EQ(mask.type(), CV_8UC1);
  cv::Mat box_region(480, 640, CV_8UC1, cv::Scalar(0));
  box_region(cv::Rect(230, 100, 140, 330)).setTo(255);
  cv::Mat wall_in_box;
  cv::bitwise_and(box_region, ~s.person, wall_in_box);
  cv::Mat eroded_wall;
  cv::erode(wall_in_box, eroded_wall, cv::Mat(), cv::Point(-1, -1), 5);
  EXPECT_GT(s.Coverage(mask, s.person), 0.99);
  EXPECT_LT(s.Coverage(mask, eroded_wall), 0.01);
  EXPECT_EQ(cv::countNonZero(mask(cv::Rect(0, 0, 200, 480))), 0);  // outside the box
}

TEST(DynamicMask, TheObjectDepthIsTheBoxForegroundWhateverTheFilterFlagged) {
  Scene s;
  // A nearer table top (1.0 m) covers the bottom of the box and is the foreground mode: it is the
  // object, whichever features the filter flagged (labels must not change the map's masks).
  cv::Mat table(480, 640, CV_8UC1, cv::Scalar(0));
  table(cv::Rect(230, 330, 140, 100)).setTo(255);
  s.depth.setTo(1.0f, table);
  cv::Mat person_visible = s.person & ~table;
  std::vector<cv::KeyPoint> kps;
  std::vector<uint8_t> dyn;
  for (int y = 150; y < 320; y += 30) {
    kps.emplace_back(cv::Point2f(300, static_cast<float>(y)), 31.f);
    dyn.push_back(1);
  }
  kps.emplace_back(cv::Point2f(240, 120), 31.f);  // static feature on the wall inside the box
  dyn.push_back(0);
  DynamicMaskOptions o;
  o.feature_radius = 0;  // no disks: the mask is the box refined by depth alone
  cv::Mat table_eroded;
  cv::erode(table, table_eroded, cv::Mat(), cv::Point(-1, -1), 5);
  const cv::Mat by_depth = ComputeDynamicMask(s.depth.size(), s.depth, s.detections, kps, dyn, o);
  EXPECT_GT(s.Coverage(by_depth, table_eroded), 0.99);
  // The person (1.6 m) is outside the table's band but for the dilation's rim along the table's
  // edge (1.4 % of the visible person measured).
  EXPECT_LT(s.Coverage(by_depth, person_visible), 0.03);
  const std::vector<uint8_t> none_flagged(dyn.size(), 0);
  const cv::Mat unlabelled =
      ComputeDynamicMask(s.depth.size(), s.depth, s.detections, kps, none_flagged, o);
  EXPECT_EQ(cv::countNonZero(by_depth != unlabelled), 0);
  EXPECT_NEAR(BoxObjectDepth(s.depth, cv::Rect(s.detections[0].box), o), 1.0, 0.05);
}

TEST(DynamicMask, FeatureDisksAndNoDepth) {
  Scene s;
  std::vector<cv::KeyPoint> kps = {cv::KeyPoint(cv::Point2f(50, 50), 31.f),
                                   cv::KeyPoint(cv::Point2f(600, 400), 31.f)};
  std::vector<uint8_t> dyn = {1, 0};
  DynamicMaskOptions o;
  o.feature_radius = 8;
  const cv::Mat mask = ComputeDynamicMask(s.depth.size(), s.depth, {}, kps, dyn, o);
  EXPECT_EQ(mask.at<uint8_t>(50, 50), 255);
  EXPECT_EQ(mask.at<uint8_t>(50, 57), 255);
  EXPECT_EQ(mask.at<uint8_t>(50, 60), 0);
  EXPECT_EQ(mask.at<uint8_t>(400, 600), 0);
  // Without depth the whole box is dynamic.
  o.dilation_px = 0;
  const cv::Mat boxes_only =
      ComputeDynamicMask(cv::Size(640, 480), cv::Mat(), s.detections, {}, {}, o);
  EXPECT_EQ(cv::countNonZero(boxes_only), 140 * 330);
  EXPECT_THROW(ComputeDynamicMask(cv::Size(640, 480), cv::Mat(480, 640, CV_16UC1), {}, {}, {}),
               InputError);
  EXPECT_THROW(ComputeDynamicMask(cv::Size(640, 480), cv::Mat(), {}, kps, {1}), InputError);
  o.depth_band = -1;
  EXPECT_THROW(ComputeDynamicMask(cv::Size(640, 480), cv::Mat(), {}, {}, {}, o), InvalidOptions);
}

}  // namespace
}  // namespace dygslam
