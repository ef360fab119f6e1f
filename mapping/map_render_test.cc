#include "mapping/map_render.h"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include "core/base/error.h"
#include "mapping/octomap_builder.h"
#include "tests/support/test_support.h"
#include "tools/synth/box_room.h"

namespace dygslam {
namespace {

class MapRender : public ::testing::Test {
 protected:
  void SetUp() override {
    const PinholeCamera camera = box_room::SmallCamera();
    OctoMapOptions options;
    options.pixel_stride = 1;
    builder_ = std::make_unique<OctoMapBuilder>(camera, options);
    for (int k = 0; k < 12; ++k) {
      builder_->Insert(
          box_room::MakeKeyframe(k, box_room::DefaultRoom(), camera,
                                   box_room::LookingAlong({-1.2, 0, 1.2}, -0.9 + 0.15 * k)));
    }
  }
  // Pixel of world (x, y) in an image of the map made with `ppc` pixels per cell.
  cv::Point PixelOf(const octomap::OcTree& map, double x, double y, int ppc) {
    double min_x, min_y, min_z, max_x, max_y, max_z;
    map.getMetricMin(min_x, min_y, min_z);
    map.getMetricMax(max_x, max_y, max_z);
    const double res = map.getResolution();
    const int rows = static_cast<int>(std::ceil((max_y - min_y) / res - 1e-6));
    const int col = static_cast<int>(std::floor((x - min_x) / res));
    const int row = rows - 1 - static_cast<int>(std::floor((y - min_y) / res));
    return {col * ppc + ppc / 2, row * ppc + ppc / 2};
  }
  std::unique_ptr<OctoMapBuilder> builder_;
};

TEST_F(MapRender, TopViewColoursOccupiedColumnsByHeight) {
  const octomap::OcTree& map = builder_->tree();
  TopViewOptions options;
  options.max_z = 2.3;  // leave out the ceiling
  options.draw_legend = false;
  const cv::Mat top = RenderTopView(map, options);
  ASSERT_EQ(top.type(), CV_8UC3);
  double min_x, min_y, min_z, max_x, max_y, max_z;
  map.getMetricMin(min_x, min_y, min_z);
  map.getMetricMax(max_x, max_y, max_z);
  EXPECT_NEAR(top.cols, (max_x - min_x) / map.getResolution() * options.pixels_per_cell, 4);
  EXPECT_NEAR(top.rows, (max_y - min_y) / map.getResolution() * options.pixels_per_cell, 4);

  const cv::Vec3b wall = top.at<cv::Vec3b>(PixelOf(map, 2.52, 0.0, 4));
  const cv::Vec3b cabinet = top.at<cv::Vec3b>(PixelOf(map, 1.52, -1.25, 4));
  const cv::Vec3b floor = top.at<cv::Vec3b>(PixelOf(map, 1.5, 0.3, 4));
  const auto grey = [](const cv::Vec3b& c) { return c[0] == c[1] && c[1] == c[2]; };
  EXPECT_FALSE(grey(wall));
  EXPECT_FALSE(grey(cabinet));
  EXPECT_FALSE(grey(floor));
  // Turbo colour map: high (wall top, 2.3 m) is red, low (floor) is blue.
  EXPECT_GT(wall[2], wall[0]);
  EXPECT_GT(floor[0], floor[2]);
  EXPECT_NE(cabinet, floor);

  const std::string path = testing::MakeTempDir("render") + "/top.png";
  WritePngAtomically(path, top);
  const cv::Mat loaded = cv::imread(path, cv::IMREAD_COLOR);
  ASSERT_FALSE(loaded.empty());
  EXPECT_EQ(cv::norm(loaded, top, cv::NORM_INF), 0.0);
  EXPECT_THROW(WritePngAtomically("/nonexistent_dir/x.png", top), InputError);
}

TEST_F(MapRender, SliceShowsWallsAndFreeSpace) {
  const octomap::OcTree& map = builder_->tree();
  SliceOptions options;
  options.pixels_per_cell = 2;
  const cv::Mat slice = RenderSlice(map, 1.2, options);
  EXPECT_EQ(slice.at<cv::Vec3b>(PixelOf(map, 2.52, 0.0, 2)), cv::Vec3b(0, 0, 0));
  EXPECT_EQ(slice.at<cv::Vec3b>(PixelOf(map, 0.5, 0.0, 2)), cv::Vec3b(255, 255, 255));
  // At 0.5 m the cabinet is in the slice, at 1.2 m it is not.
  EXPECT_EQ(RenderSlice(map, 0.5, options).at<cv::Vec3b>(PixelOf(map, 1.52, -1.25, 2)),
            cv::Vec3b(0, 0, 0));
  EXPECT_NE(slice.at<cv::Vec3b>(PixelOf(map, 1.52, -1.25, 2)), cv::Vec3b(0, 0, 0));
  // Empty map: a tiny placeholder, no crash.
  EXPECT_EQ(RenderTopView(octomap::OcTree(0.05)).total(), 1u);
}

}  // namespace
}  // namespace dygslam
