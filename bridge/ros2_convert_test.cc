#include "bridge/ros2_convert.h"

#include <cstring>
#include <sstream>

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

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
  auto yuv = MakeImage(4, 4, "yuv422", 2);
  try {
    ColorFromRos(yuv, "/cam/color");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/cam/color.encoding: 'yuv422'"), std::string::npos);
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
  EXPECT_FALSE(r.ignored_distortion);

  // Azure Kinect style: rational_polynomial with 8 coefficients.
  info.distortion_model("rational_polynomial");
  info.d({0.1, 0.2, 0.001, 0.002, 0.3, 0.4, 0.5, 0.6});
  r = CameraFromRos(info, "info");
  EXPECT_DOUBLE_EQ(r.camera.k3, 0.3);
  EXPECT_TRUE(r.ignored_distortion);

  info.distortion_model("equidistant");
  info.d({0.1, 0.2, 0.3, 0.4});
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
    poses.push_back({Timestamp::FromNanoseconds(i * 100000000LL),
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
