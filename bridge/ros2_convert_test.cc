#include "bridge/ros2_convert.h"

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <cstring>
#include <iostream>
#include <map>
#include <opencv2/calib3d.hpp>
#include <sstream>

#include "bridge/ros2_qos.h"
#include "core/base/error.h"

namespace dygslam::ros2 {
namespace {

sensor_msgs::msg::Image MakeImage(uint32_t w, uint32_t h, const std::string& encoding, int bpp,
                                  uint32_t padding = 0) {
  sensor_msgs::msg::Image m;
  m.width(w);
  m.height(h);
  m.encoding(encoding);
  m.step(w * bpp + padding);
  m.data().assign(static_cast<size_t>(m.step()) * h, 0);
  return m;
}

TEST(Convert, TimeRoundTripAndNanosecValidation) {
  const Timestamp t = Timestamp::FromNanoseconds(1548339823898123456);
  const auto m = TimeToRos(t);
  EXPECT_EQ(m.sec(), 1548339823);
  EXPECT_EQ(m.nanosec(), 898123456u);
  EXPECT_EQ(TimeFromRos(m, "x"), t);
  builtin_interfaces::msg::Time bad;
  bad.nanosec(1000000000u);
  try {
    TimeFromRos(bad, "/camera/color/image_raw.header.stamp");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("image_raw.header.stamp.nanosec"), std::string::npos);
  }
}

TEST(Convert, ColorEncodingsGiveBgrAndHonourRowPadding) {
  // One pixel row with padding: RGB (10, 20, 30) must arrive as BGR (30, 20, 10).
  auto rgb = MakeImage(3, 2, "rgb8", 3, 7);
  for (uint32_t r = 0; r < 2; ++r) {
    for (uint32_t c = 0; c < 3; ++c) {
      uint8_t* px = rgb.data().data() + r * rgb.step() + c * 3;
      px[0] = 10 + c;
      px[1] = 20;
      px[2] = 30 + r;
    }
  }
  const cv::Mat bgr = ColorFromRos(rgb, "color");
  ASSERT_EQ(bgr.type(), CV_8UC3);
  ASSERT_EQ(bgr.size(), cv::Size(3, 2));
  EXPECT_EQ(bgr.at<cv::Vec3b>(1, 2), cv::Vec3b(31, 20, 12));

  auto bgra = MakeImage(2, 1, "bgra8", 4);
  bgra.data() = {1, 2, 3, 255, 4, 5, 6, 255};
  const cv::Mat b = ColorFromRos(bgra, "color");
  EXPECT_EQ(b.at<cv::Vec3b>(0, 1), cv::Vec3b(4, 5, 6));

  auto mono = MakeImage(1, 1, "mono8", 1);
  mono.data() = {77};
  EXPECT_EQ(ColorFromRos(mono, "color").at<cv::Vec3b>(0, 0), cv::Vec3b(77, 77, 77));
}

TEST(Convert, BadImagesNameTheField) {
  auto short_data = MakeImage(640, 480, "bgr8", 3);
  short_data.data().resize(1000);
  try {
    ColorFromRos(short_data, "/cam/color");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/cam/color.data: 1000 bytes"), std::string::npos)
        << e.what();
  }
  auto small_step = MakeImage(640, 480, "bgr8", 3);
  small_step.step(640);
  EXPECT_THROW(ColorFromRos(small_step, "c"), InputError);
  auto nv21 = MakeImage(4, 4, "nv21", 2);
  try {
    ColorFromRos(nv21, "/cam/color");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/cam/color.encoding: 'nv21'"), std::string::npos);
  }
  EXPECT_THROW(DepthFromRos(MakeImage(4, 4, "bgr8", 3), 0.001, "d"), InputError);
  EXPECT_THROW(ColorFromRos(MakeImage(0, 4, "bgr8", 3), "c"), InputError);
}

TEST(Convert, Depth16UC1MillimetresIsScaledToMetresNotTumFactor) {
  auto m = MakeImage(2, 1, "16UC1", 2);
  const uint16_t v[2] = {1500, 0};  // 1.5 m, no measurement
  std::memcpy(m.data().data(), v, 4);
  const DepthImage d = DepthFromRos(m, 0.001, "depth");
  ASSERT_EQ(d.depth.type(), CV_16UC1);
  EXPECT_DOUBLE_EQ(d.depth_scale, 1000.0);
  EXPECT_DOUBLE_EQ(d.depth.at<uint16_t>(0, 0) / d.depth_scale, 1.5);
  EXPECT_EQ(d.depth.at<uint16_t>(0, 1), 0);

  // Big-endian 16-bit: 1500 = 0x05DC.
  auto be = MakeImage(1, 1, "16UC1", 2);
  be.is_bigendian(1);
  be.data() = {0x05, 0xDC};
  EXPECT_EQ(DepthFromRos(be, 0.001, "depth").depth.at<uint16_t>(0, 0), 1500);

  // A sensor with 0.25 mm units.
  EXPECT_DOUBLE_EQ(DepthFromRos(m, 0.00025, "depth").depth_scale, 4000.0);
}

TEST(Convert, Depth32FC1MetresInvalidValuesBecomeZero) {
  auto m = MakeImage(4, 1, "32FC1", 4);
  const float v[4] = {2.25f, std::nanf(""), -1.f, std::numeric_limits<float>::infinity()};
  std::memcpy(m.data().data(), v, 16);
  const DepthImage d = DepthFromRos(m, 0.001, "depth");
  ASSERT_EQ(d.depth.type(), CV_32FC1);
  EXPECT_DOUBLE_EQ(d.depth_scale, 1.0);
  EXPECT_FLOAT_EQ(d.depth.at<float>(0, 0), 2.25f);
  EXPECT_EQ(d.depth.at<float>(0, 1), 0.f);
  EXPECT_EQ(d.depth.at<float>(0, 2), 0.f);
  EXPECT_EQ(d.depth.at<float>(0, 3), 0.f);
}

TEST(Convert, ImageToRosRoundTrip) {
  cv::Mat depth(3, 5, CV_16UC1);
  cv::randu(depth, 0, 60000);
  const auto m = ImageToRos(depth, Timestamp::FromNanoseconds(5), "cam");
  EXPECT_EQ(m.encoding(), "16UC1");
  EXPECT_EQ(m.step(), 10u);
  const DepthImage back = DepthFromRos(m, 0.001, "d");
  EXPECT_EQ(cv::norm(back.depth, depth, cv::NORM_INF), 0.0);
}

TEST(Convert, CameraInfoIntrinsicsAndDistortion) {
  PinholeCamera c;
  c.fx = 542.8;
  c.fy = 542.5;
  c.cx = 315.6;
  c.cy = 237.7;
  c.k1 = 0.04;
  c.k2 = -0.1;
  c.p1 = -0.0007;
  c.p2 = -0.0001;
  auto info = CameraToRos(c, Timestamp(), "cam");
  RosCamera r = CameraFromRos(info, "info");
  EXPECT_DOUBLE_EQ(r.camera.fx, c.fx);
  EXPECT_DOUBLE_EQ(r.camera.fy, c.fy);
  EXPECT_DOUBLE_EQ(r.camera.cx, c.cx);
  EXPECT_DOUBLE_EQ(r.camera.cy, c.cy);
  EXPECT_DOUBLE_EQ(r.camera.k1, c.k1);
  EXPECT_DOUBLE_EQ(r.camera.p2, c.p2);
  EXPECT_EQ(r.camera.width, 640);
  EXPECT_FALSE(r.rectify);

  // Azure Kinect style: rational_polynomial with 8 coefficients: all kept, images rectified, the
  // pipeline's camera has no distortion.
  info.distortion_model("rational_polynomial");
  info.d({0.1, 0.2, 0.001, 0.002, 0.3, 0.4, 0.5, 0.6});
  r = CameraFromRos(info, "info");
  EXPECT_TRUE(r.rectify);
  EXPECT_EQ(r.model, DistortionModel::kRationalPolynomial);
  EXPECT_EQ(r.coefficients, std::vector<double>({0.1, 0.2, 0.001, 0.002, 0.3, 0.4, 0.5, 0.6}));
  EXPECT_FALSE(r.camera.HasDistortion());
  // rational_polynomial with k4..k6 = 0 is plumb_bob: passed on, no rectification.
  info.d({0.1, 0.2, 0.001, 0.002, 0.3, 0, 0, 0});
  r = CameraFromRos(info, "info");
  EXPECT_FALSE(r.rectify);
  EXPECT_DOUBLE_EQ(r.camera.k3, 0.3);
  info.d({0.1, 0.2, 0.001, 0.002, 0.3, 0.4, 0.5, 0.6, 0.7});
  EXPECT_THROW(CameraFromRos(info, "info"), InputError);  // 9 coefficients

  info.distortion_model("equidistant");
  info.d({0.1, 0.2, 0.3, 0.4});
  r = CameraFromRos(info, "info");
  EXPECT_EQ(r.model, DistortionModel::kEquidistant);
  EXPECT_TRUE(r.rectify);
  EXPECT_FALSE(r.camera.HasDistortion());
  info.d({0.1, 0.2, 0.3, 0.4, 0.5});
  EXPECT_THROW(CameraFromRos(info, "info"), InputError);

  info.distortion_model("double_sphere");
  try {
    CameraFromRos(info, "/rgb/camera_info");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/rgb/camera_info.distortion_model"), std::string::npos);
  }
  info.distortion_model("plumb_bob");
  info.d({});
  info.k()[0] = 0;
  EXPECT_THROW(CameraFromRos(info, "i"), InputError);  // uncalibrated
  info.k()[0] = 500;
  info.binning_x(2);
  EXPECT_THROW(CameraFromRos(info, "i"), InputError);
}

// YUV 4:2:2 in both byte orders: a BT.601 (limited range) pure red Y=81 Cb=90 Cr=240 and grey
// Y=126 Cb=Cr=128 must come out as BGR (0, 0, 255) and (128, 128, 128) (OpenCV's conversion
// rounds; +-3). Swapping the two layouts would give other colours, so each order is checked.
TEST(Convert, Yuv422BothByteOrdersGiveTheColour) {
  for (const std::string encoding : {"yuv422", "yuv422_yuy2"}) {
    auto m = MakeImage(4, 2, encoding, 2, 4);  // 2 bytes per pixel + row padding
    for (uint32_t r = 0; r < 2; ++r) {
      for (uint32_t pair = 0; pair < 2; ++pair) {
        const bool red = pair == 0;
        const uint8_t y = red ? 81 : 126, u = red ? 90 : 128, v = red ? 240 : 128;
        uint8_t* p = m.data().data() + r * m.step() + pair * 4;
        if (encoding == "yuv422") {  // UYVY
          p[0] = u, p[1] = y, p[2] = v, p[3] = y;
        } else {  // YUYV
          p[0] = y, p[1] = u, p[2] = y, p[3] = v;
        }
      }
    }
    const cv::Mat bgr = ColorFromRos(m, "color");
    ASSERT_EQ(bgr.type(), CV_8UC3) << encoding;
    for (int r = 0; r < 2; ++r) {
      for (int c = 0; c < 4; ++c) {
        const cv::Vec3b expected = c < 2 ? cv::Vec3b(0, 0, 255) : cv::Vec3b(128, 128, 128);
        for (int k = 0; k < 3; ++k) {
          EXPECT_NEAR(bgr.at<cv::Vec3b>(r, c)[k], expected[k], 3)
              << encoding << " pixel " << r << "," << c << " channel " << k;
        }
      }
    }
  }
  auto odd = MakeImage(3, 2, "yuv422", 2);
  EXPECT_THROW(ColorFromRos(odd, "color"), InputError);
}

// Bayer: a scene of uniform colour patches is mosaicked by hand in each ROS pattern (the name
// lists the colours of the top-left 2x2 cell row by row), 8- and 16-bit; the demosaiced image
// has the patch colours inside the patches.
TEST(Convert, BayerPatternsDemosaicToTheSceneColours) {
  const cv::Vec3b patches[4] = {{40, 90, 200}, {200, 60, 30}, {30, 180, 60}, {120, 120, 120}};
  const int side = 16, w = 2 * side, h = 2 * side;
  auto colour_at = [&](int r, int c) { return patches[(r / side) * 2 + c / side]; };
  const std::map<std::string, std::string> patterns = {
      {"rggb", "RGGB"}, {"bggr", "BGGR"}, {"gbrg", "GBRG"}, {"grbg", "GRBG"}};
  for (const auto& [name, cell] : patterns) {
    for (const bool sixteen : {false, true}) {
      const std::string encoding = "bayer_" + name + (sixteen ? "16" : "8");
      auto m = MakeImage(w, h, encoding, sixteen ? 2 : 1);
      for (int r = 0; r < h; ++r) {
        for (int c = 0; c < w; ++c) {
          const char which = cell[(r % 2) * 2 + c % 2];
          const int channel = which == 'B' ? 0 : which == 'G' ? 1 : 2;
          const uint8_t v = colour_at(r, c)[channel];
          if (sixteen) {
            const uint16_t v16 = static_cast<uint16_t>(v << 8 | 0x5a);  // low byte is dropped
            std::memcpy(m.data().data() + r * m.step() + 2 * c, &v16, 2);
          } else {
            m.data()[r * m.step() + c] = v;
          }
        }
      }
      const cv::Mat bgr = ColorFromRos(m, "color");
      ASSERT_EQ(bgr.size(), cv::Size(w, h));
      int checked = 0;
      for (int r = 0; r < h; ++r) {
        for (int c = 0; c < w; ++c) {
          // Away from patch borders (demosaicing mixes neighbours) and the image border.
          if (r % side < 3 || r % side > side - 4 || c % side < 3 || c % side > side - 4) continue;
          for (int k = 0; k < 3; ++k) {
            ASSERT_NEAR(bgr.at<cv::Vec3b>(r, c)[k], colour_at(r, c)[k], 2)
                << encoding << " at " << r << "," << c << " channel " << k;
          }
          ++checked;
        }
      }
      EXPECT_EQ(checked, 4 * 10 * 10);
    }
  }
}

TEST(Convert, Mono16ColourIsTheHighByteInBothByteOrders) {
  auto m = MakeImage(2, 1, "mono16", 2);
  m.data() = {0x34, 0x12, 0xff, 0x80};  // little endian 0x1234, 0x80ff
  cv::Mat bgr = ColorFromRos(m, "ir");
  EXPECT_EQ(bgr.at<cv::Vec3b>(0, 0), cv::Vec3b(0x12, 0x12, 0x12));
  EXPECT_EQ(bgr.at<cv::Vec3b>(0, 1), cv::Vec3b(0x80, 0x80, 0x80));
  m.is_bigendian(1);
  bgr = ColorFromRos(m, "ir");
  EXPECT_EQ(bgr.at<cv::Vec3b>(0, 0), cv::Vec3b(0x34, 0x34, 0x34));
}

// Rectification against OpenCV's forward projection: the distorted input holds its own pixel
// coordinates, so after rectification the pixel at the ideal position u must hold the distorted
// position of u's ray, as cv::projectPoints (rational_polynomial, 8 coefficients) or
// cv::fisheye::projectPoints (equidistant) computes it.
struct RectifyCase {
  std::string model;
  PinholeCamera k;
  std::vector<double> d;
};

std::vector<cv::Point2f> ProjectReference(const RectifyCase& c,
                                          const std::vector<cv::Point3f>& rays,
                                          const std::vector<double>& d) {
  std::vector<cv::Point2f> out;
  const cv::Mat zero = cv::Mat::zeros(3, 1, CV_64F);
  if (c.model == "equidistant") {
    cv::fisheye::projectPoints(rays, out, zero, zero, c.k.K(), d);
  } else {
    cv::projectPoints(rays, zero, zero, c.k.K(), d, out);
  }
  return out;
}

void CheckRectification(const RectifyCase& c, double min_truncation_error_px) {
  sensor_msgs::msg::CameraInfo info = CameraToRos(c.k, Timestamp(), "cam");
  info.distortion_model(c.model);
  info.d(c.d);
  const RosCamera camera = CameraFromRos(info, "info");
  ASSERT_TRUE(camera.rectify);
  const ImageRectifier rectifier(camera);
  ASSERT_TRUE(rectifier.active());
  cv::Mat coords(c.k.height, c.k.width, CV_32FC2);
  for (int r = 0; r < coords.rows; ++r) {
    for (int col = 0; col < coords.cols; ++col)
      coords.at<cv::Vec2f>(r, col) = {float(col), float(r)};
  }
  const cv::Mat rectified = rectifier.Color(coords);
  const cv::Mat nearest = rectifier.Depth(coords);
  // Ideal pixels on a grid over the central 80 % of the image.
  std::vector<cv::Point2f> ideal;
  std::vector<cv::Point3f> rays;
  for (int r = c.k.height / 10; r < c.k.height * 9 / 10; r += 17) {
    for (int col = c.k.width / 10; col < c.k.width * 9 / 10; col += 19) {
      ideal.emplace_back(col, r);
      rays.emplace_back((col - c.k.cx) / c.k.fx, (r - c.k.cy) / c.k.fy, 1.f);
    }
  }
  const std::vector<cv::Point2f> reference = ProjectReference(c, rays, c.d);
  double max_error = 0, max_nearest = 0;
  int inside = 0;
  for (size_t i = 0; i < ideal.size(); ++i) {
    const cv::Point2f& p = reference[i];
    if (p.x < 1 || p.y < 1 || p.x > c.k.width - 2 || p.y > c.k.height - 2) continue;
    ++inside;
    const cv::Vec2f got = rectified.at<cv::Vec2f>(int(ideal[i].y), int(ideal[i].x));
    max_error = std::max(max_error, double(cv::norm(cv::Point2f(got[0], got[1]) - p)));
    const cv::Vec2f n = nearest.at<cv::Vec2f>(int(ideal[i].y), int(ideal[i].x));
    max_nearest = std::max(max_nearest, double(cv::norm(cv::Point2f(n[0], n[1]) - p)));
  }
  EXPECT_GT(inside, 200) << c.model;
  std::cout << c.model << ": rectified vs OpenCV projection, max " << max_error
            << " px (bilinear), " << max_nearest << " px (nearest), " << inside << " points\n";
  // Measured: ~0.01 px (the maps are float; bilinear interpolation of coordinates is exact).
  EXPECT_LT(max_error, 0.05) << c.model;
  EXPECT_LE(max_nearest, 0.75) << c.model;  // nearest neighbour: within half a pixel per axis
  // What dropping the extra coefficients would cost (rational: only k1 k2 p1 p2 k3, as before).
  if (c.model == "rational_polynomial") {
    const std::vector<double> five(c.d.begin(), c.d.begin() + 5);
    const std::vector<cv::Point2f> truncated = ProjectReference(c, rays, five);
    double worst = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
      worst = std::max(worst, double(cv::norm(truncated[i] - reference[i])));
    }
    std::cout << "rational_polynomial cut to 5 coefficients: up to " << worst
              << " px off in the central 80 % of the image\n";
    EXPECT_GT(worst, min_truncation_error_px);
  }
}

TEST(Convert, RationalPolynomialEightCoefficientsRectifyAsOpenCvProjects) {
  // Azure Kinect colour camera (1280x720) calibration of the rational model.
  RectifyCase c;
  c.model = "rational_polynomial";
  c.k.width = 1280;
  c.k.height = 720;
  c.k.fx = 605.8;
  c.k.fy = 605.6;
  c.k.cx = 637.9;
  c.k.cy = 367.3;
  c.d = {0.4939, -2.6706, 0.00052, -0.00021, 1.5226, 0.3729, -2.5011, 1.4474};
  CheckRectification(c, 100.0);  // measured: 419 px at the edge of the central 80 %
}

TEST(Convert, EquidistantRectifiesAsOpenCvFisheyeProjects) {
  // RealSense T265 style fisheye (848x800).
  RectifyCase c;
  c.model = "equidistant";
  c.k.width = 848;
  c.k.height = 800;
  c.k.fx = 286.2;
  c.k.fy = 286.3;
  c.k.cx = 421.4;
  c.k.cy = 398.9;
  c.d = {-0.0077, 0.0433, -0.0405, 0.0076};
  CheckRectification(c, 0);
}

TEST(Convert, FrameIdWithLeadingSlashIsRejected) {
  EXPECT_NO_THROW(CheckFrameId("camera_color_optical_frame", "x"));
  EXPECT_NO_THROW(CheckFrameId("", "x"));
  try {
    CheckFrameId("/camera_link", "/camera/color/image_raw.header.frame_id");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/camera/color/image_raw.header.frame_id"),
              std::string::npos);
    EXPECT_NE(std::string(e.what()).find("tf2"), std::string::npos);
  }
}

TEST(Convert, MapAxesAreRep103) {
  const Rigid3d m = MapFromWorld(true);
  // Optical z (forward) -> map x; optical x (right) -> map -y; optical y (down) -> map -z.
  EXPECT_TRUE((m * Eigen::Vector3d(0, 0, 1)).isApprox(Eigen::Vector3d(1, 0, 0)));
  EXPECT_TRUE((m * Eigen::Vector3d(1, 0, 0)).isApprox(Eigen::Vector3d(0, -1, 0)));
  EXPECT_TRUE((m * Eigen::Vector3d(0, 1, 0)).isApprox(Eigen::Vector3d(0, 0, -1)));
  EXPECT_NEAR(m.RotationMatrix().determinant(), 1.0, 1e-12);
  EXPECT_TRUE(MapFromWorld(false).ToMatrix().isIdentity());
}

TEST(Convert, PathTransformAndOdometry) {
  const Rigid3d map_from_world = MapFromWorld(true);
  std::vector<StampedPose> poses;
  for (int i = 0; i < 3; ++i) {
    poses.push_back(
        {Timestamp::FromNanoseconds(i * 100000000LL),
         Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.1 * i, Eigen::Vector3d::UnitY())),
                 Eigen::Vector3d(0.0, 0.0, 0.5 * i))});
  }
  const auto path = PathToRos(poses, map_from_world, poses.back().stamp, "map");
  ASSERT_EQ(path.poses().size(), 3u);
  EXPECT_EQ(path.header().frame_id(), "map");
  // 0.5 m / step forward along optical z = +x in the map.
  EXPECT_NEAR(path.poses()[2].pose().position().x(), 1.0, 1e-12);
  EXPECT_NEAR(path.poses()[2].pose().position().z(), 0.0, 1e-12);
  EXPECT_EQ(path.poses()[1].header().stamp().nanosec(), 100000000u);
  const Rigid3d back = PoseFromRos(path.poses()[2].pose());
  EXPECT_TRUE(back.rotation.isApprox((map_from_world * poses[2].world_from_cam).rotation) ||
              back.rotation.coeffs().isApprox(
                  -(map_from_world * poses[2].world_from_cam).rotation.coeffs()));

  // Odometry twist in the camera frame: forward 5 m/s along optical z, yaw 1 rad/s about y.
  const StampedPose a{poses[0].stamp, map_from_world * poses[0].world_from_cam};
  const StampedPose b{poses[1].stamp, map_from_world * poses[1].world_from_cam};
  const auto odom = OdometryToRos(b, a, "map", "cam");
  EXPECT_EQ(odom.child_frame_id(), "cam");
  const auto& lin = odom.twist().twist().linear();
  const auto& ang = odom.twist().twist().angular();
  // Camera moved 0.5 m along world z while rotated 0.1 rad about y: in the new camera frame
  // the displacement is R_b^T (0, 0, 0.5).
  const Eigen::Vector3d expected =
      poses[1].world_from_cam.rotation.conjugate() * Eigen::Vector3d(0, 0, 0.5) / 0.1;
  EXPECT_NEAR(lin.x(), expected.x(), 1e-9);
  EXPECT_NEAR(lin.z(), expected.z(), 1e-9);
  EXPECT_NEAR(ang.y(), 1.0, 1e-9);
  EXPECT_NEAR(ang.x(), 0.0, 1e-9);
  const auto first = OdometryToRos(a, std::nullopt, "map", "cam");
  EXPECT_EQ(first.twist().twist().linear().z(), 0.0);
}

TEST(Convert, DetectionsBecomeCentredBoxesWithStringClass) {
  Detection person;
  person.box = cv::Rect2f(100, 50, 40, 120);
  person.class_id = 0;
  person.label = "person";
  person.score = 0.75f;
  Detection unnamed;
  unnamed.box = cv::Rect2f(0, 0, 10, 10);
  unnamed.class_id = 56;
  const auto m = DetectionsToRos({person, unnamed}, Timestamp::FromNanoseconds(7), "cam_optical");
  ASSERT_EQ(m.detections().size(), 2u);
  const auto& d = m.detections()[0];
  EXPECT_EQ(d.header().frame_id(), "cam_optical");
  EXPECT_DOUBLE_EQ(d.bbox().center().position().x(), 120.0);
  EXPECT_DOUBLE_EQ(d.bbox().center().position().y(), 110.0);
  EXPECT_DOUBLE_EQ(d.bbox().size_x(), 40.0);
  EXPECT_DOUBLE_EQ(d.bbox().size_y(), 120.0);
  ASSERT_EQ(d.results().size(), 1u);
  EXPECT_EQ(d.results()[0].hypothesis().class_id(), "person");
  EXPECT_NEAR(d.results()[0].hypothesis().score(), 0.75, 1e-7);
  EXPECT_EQ(d.results()[0].pose().pose().orientation().w(), 1.0);
  EXPECT_EQ(m.detections()[1].results()[0].hypothesis().class_id(), "56");
}

TEST(Convert, OctomapMessageIsReadableLikeOctomapMsgs) {
  octomap::OcTree tree(0.05);
  for (int i = 0; i < 20; ++i) tree.updateNode(octomap::point3d(0.05f * i, 0.1f, 1.0f), true);
  tree.updateNode(octomap::point3d(0.0f, 0.0f, 0.5f), false);
  std::ostringstream bt;
  ASSERT_TRUE(tree.writeBinary(bt));
  const std::string s = bt.str();
  const auto m = OctomapToRos(std::vector<uint8_t>(s.begin(), s.end()),
                              Timestamp::FromNanoseconds(3), "dygslam_world");
  EXPECT_TRUE(m.binary());
  EXPECT_EQ(m.id(), "OcTree");
  EXPECT_DOUBLE_EQ(m.resolution(), 0.05);
  EXPECT_EQ(m.header().frame_id(), "dygslam_world");
  // What octomap_msgs::binaryMsgToMap does: OcTree(resolution) + readBinaryData(data).
  octomap::OcTree back(m.resolution());
  std::stringstream in;
  in.write(reinterpret_cast<const char*>(m.data().data()), m.data().size());
  back.readBinaryData(in);
  EXPECT_EQ(back.getNumLeafNodes(), tree.getNumLeafNodes());
  auto* hit = back.search(octomap::point3d(0.5f, 0.1f, 1.0f));
  ASSERT_NE(hit, nullptr);
  EXPECT_TRUE(back.isNodeOccupied(hit));
  EXPECT_THROW(OctomapToRos({1, 2, 3}, Timestamp(), "w"), InputError);
}

TEST(Convert, RosTopicNames) {
  EXPECT_EQ(DdsTopicName("/camera/color/image_raw", "t"), "rt/camera/color/image_raw");
  EXPECT_EQ(DdsTopicName("tf", "t"), "rt/tf");
  EXPECT_THROW(DdsTopicName("", "t"), InvalidOptions);
  EXPECT_THROW(DdsTopicName("/a//b", "t"), InvalidOptions);
  EXPECT_THROW(DdsTopicName("/a/b/", "t"), InvalidOptions);
  EXPECT_THROW(DdsTopicName("/a/1b", "t"), InvalidOptions);
  try {
    DdsTopicName("/cam era", "color_topic");
    FAIL();
  } catch (const InvalidOptions& e) {
    EXPECT_NE(std::string(e.what()).find("color_topic"), std::string::npos);
  }
}

}  // namespace
}  // namespace dygslam::ros2
