#include "components/convert.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <string>

#include "core/base/error.h"

namespace dygslam {
namespace {

PinholeCamera TestCamera(int w = 64, int h = 48) {
  PinholeCamera c;
  c.fx = 542.8;
  c.fy = 542.5;
  c.cx = 31.5;
  c.cy = 23.7;
  c.k1 = 0.01;
  c.k2 = -0.02;
  c.p1 = 0.001;
  c.p2 = -0.001;
  c.k3 = 0.003;
  c.width = w;
  c.height = h;
  return c;
}

RgbdFrameData TestFrame() {
  RgbdFrameData f;
  f.stamp = *Timestamp::Parse("1548339823.898123");
  f.seq = 17;
  f.camera = TestCamera();
  f.rgb = cv::Mat(48, 64, CV_8UC3);
  cv::randu(f.rgb, 0, 255);
  f.depth = cv::Mat(48, 64, CV_16UC1);
  cv::randu(f.depth, 0, 60000);
  return f;
}

// Asserts that `fn` throws InputError whose message contains `field`.
template <class Fn>
void ExpectInputError(Fn fn, const std::string& field) {
  try {
    fn();
    FAIL() << "expected InputError naming " << field;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(field), std::string::npos)
        << "message '" << e.what() << "' does not name " << field;
  }
}

TEST(Convert, TimeRoundTripIncludingNegative) {
  for (int64_t ns : {int64_t{0}, int64_t{1548339823898123000}, int64_t{-1}, int64_t{-1500000000},
                     int64_t{999999999}}) {
    const msg::Time t = TimeToMsg(Timestamp::FromNanoseconds(ns));
    EXPECT_LT(t.nanosec(), 1000000000u);
    EXPECT_EQ(TimeFromMsg(t, "t").nanoseconds(), ns);
  }
  msg::Time bad;
  bad.sec(1);
  bad.nanosec(1000000000u);
  ExpectInputError([&] { TimeFromMsg(bad, "X.stamp"); }, "X.stamp.nanosec");
}

TEST(Convert, PoseRoundTripAndValidation) {
  const Rigid3d pose(
      Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized())),
      Eigen::Vector3d(1.5, -2.0, 0.25));
  const Rigid3d back = PoseFromMsg(PoseToMsg(pose), "p");
  EXPECT_LT((back.translation - pose.translation).norm(), 1e-12);
  EXPECT_LT(back.rotation.angularDistance(pose.rotation), 1e-12);

  msg::Pose nan_pose = PoseToMsg(pose);
  nan_pose.position().y(std::numeric_limits<double>::quiet_NaN());
  ExpectInputError([&] { PoseFromMsg(nan_pose, "Foo.pose"); }, "Foo.pose.position");
  msg::Pose inf_q = PoseToMsg(pose);
  inf_q.orientation().w(std::numeric_limits<double>::infinity());
  ExpectInputError([&] { PoseFromMsg(inf_q, "Foo.pose"); }, "Foo.pose.orientation");
  msg::Pose zero_q = PoseToMsg(pose);
  zero_q.orientation(msg::Quaternion());
  ExpectInputError([&] { PoseFromMsg(zero_q, "Foo.pose"); }, "Foo.pose.orientation");
}

TEST(Convert, ImageRoundTripAllEncodings) {
  for (int type : {CV_8UC3, CV_8UC1, CV_16UC1, CV_32FC1}) {
    cv::Mat m(13, 7, type);
    cv::randu(m, 0, 200);
    const cv::Mat back = ImageFromMsg(ImageToMsg(m), "img");
    ASSERT_EQ(back.type(), type);
    ASSERT_EQ(back.size(), m.size());
    EXPECT_EQ(cv::norm(back, m, cv::NORM_INF), 0.0);
  }
  // Non-continuous (ROI) input is packed.
  cv::Mat big(20, 20, CV_16UC1);
  cv::randu(big, 0, 1000);
  const cv::Mat roi = big(cv::Rect(3, 4, 5, 6));
  const msg::Image m = ImageToMsg(roi);
  EXPECT_EQ(m.step(), 10u);
  EXPECT_EQ(m.data().size(), 60u);
  EXPECT_EQ(cv::norm(ImageFromMsg(m, "roi"), roi, cv::NORM_INF), 0.0);
  // Empty stays empty.
  EXPECT_TRUE(ImageFromMsg(ImageToMsg(cv::Mat()), "e").empty());
}

TEST(Convert, Rgb8IsConvertedToBgr) {
  msg::Image m;
  m.width(1);
  m.height(1);
  m.encoding("rgb8");
  m.step(3);
  m.data({10, 20, 30});
  const cv::Mat bgr = ImageFromMsg(m, "img");
  ASSERT_EQ(bgr.type(), CV_8UC3);
  EXPECT_EQ(bgr.at<cv::Vec3b>(0, 0), cv::Vec3b(30, 20, 10));
}

TEST(Convert, ImageBadSizesNameTheField) {
  cv::Mat depth(48, 64, CV_16UC1, cv::Scalar(1000));
  msg::Image good = ImageToMsg(depth);

  msg::Image short_data = good;
  short_data.data().resize(good.data().size() - 2);
  ExpectInputError([&] { ImageFromMsg(short_data, "RgbdFrame.depth"); }, "RgbdFrame.depth.data");

  msg::Image bad_width = good;
  bad_width.width(65);
  ExpectInputError([&] { ImageFromMsg(bad_width, "RgbdFrame.depth"); }, "RgbdFrame.depth.step");

  msg::Image bad_step = good;
  bad_step.step(good.step() + 2);
  ExpectInputError([&] { ImageFromMsg(bad_step, "RgbdFrame.depth"); }, "RgbdFrame.depth.step");

  msg::Image unknown = good;
  unknown.encoding("yuv422");
  ExpectInputError([&] { ImageFromMsg(unknown, "RgbdFrame.depth"); }, "RgbdFrame.depth.encoding");

  msg::Image absurd = good;
  absurd.width(100000);
  ExpectInputError([&] { ImageFromMsg(absurd, "RgbdFrame.depth"); }, "RgbdFrame.depth.width");
  msg::Image zero_h = good;
  zero_h.height(0);
  ExpectInputError([&] { ImageFromMsg(zero_h, "RgbdFrame.depth"); }, "RgbdFrame.depth.height");
}

TEST(Convert, RgbdFrameRoundTrip) {
  const RgbdFrameData f = TestFrame();
  const msg::RgbdFrame m = RgbdFrameToMsg(f);
  EXPECT_EQ(m.color().encoding(), "bgr8");
  EXPECT_EQ(m.depth().encoding(), "16UC1");
  const RgbdFrameData back = RgbdFrameFromMsg(m);
  EXPECT_EQ(back.stamp, f.stamp);
  EXPECT_EQ(back.seq, 17u);
  EXPECT_EQ(back.depth_scale, 5000.0);
  EXPECT_EQ(back.camera.fx, f.camera.fx);
  EXPECT_EQ(back.camera.k3, f.camera.k3);
  EXPECT_EQ(back.camera.width, 64);
  EXPECT_EQ(cv::norm(back.rgb, f.rgb, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(back.depth, f.depth, cv::NORM_INF), 0.0);
}

TEST(Convert, RgbdFrameInconsistentSamplesAreRejected) {
  const msg::RgbdFrame good = RgbdFrameToMsg(TestFrame());

  msg::RgbdFrame wrong_camera = good;
  wrong_camera.camera().width(80);
  ExpectInputError([&] { RgbdFrameFromMsg(wrong_camera); }, "RgbdFrame.color");

  msg::RgbdFrame depth_as_color = good;
  depth_as_color.depth().encoding("bgr8");
  ExpectInputError([&] { RgbdFrameFromMsg(depth_as_color); }, "RgbdFrame.depth.encoding");

  msg::RgbdFrame truncated = good;
  truncated.color().data().pop_back();
  ExpectInputError([&] { RgbdFrameFromMsg(truncated); }, "RgbdFrame.color.data");

  msg::RgbdFrame bad_fx = good;
  bad_fx.camera().fx(std::numeric_limits<double>::quiet_NaN());
  ExpectInputError([&] { RgbdFrameFromMsg(bad_fx); }, "RgbdFrame.camera.fx");

  msg::RgbdFrame bad_dist = good;
  bad_dist.camera().distortion({0.1, 0.2});
  ExpectInputError([&] { RgbdFrameFromMsg(bad_dist); }, "RgbdFrame.camera.distortion");

  msg::RgbdFrame bad_scale = good;
  bad_scale.camera().depth_scale(0);
  ExpectInputError([&] { RgbdFrameFromMsg(bad_scale); }, "RgbdFrame.camera.depth_scale");

  msg::RgbdFrame bad_stamp = good;
  bad_stamp.header().stamp().nanosec(2000000000u);
  ExpectInputError([&] { RgbdFrameFromMsg(bad_stamp); }, "RgbdFrame.header.stamp.nanosec");
}

TEST(Convert, DetectionsRoundTripAndValidation) {
  std::vector<Detection> dets(2);
  dets[0].box = cv::Rect2f(1.5f, 2.5f, 30.f, 60.f);
  dets[0].class_id = 0;
  dets[0].label = "person";
  dets[0].score = 0.9f;
  dets[1].box = cv::Rect2f(100.f, 20.f, 5.f, 6.f);
  dets[1].class_id = 56;
  dets[1].label = "chair";
  dets[1].score = 0.4f;
  const Timestamp stamp = Timestamp::FromNanoseconds(123456789);
  msg::Detections m = DetectionsToMsg(dets, stamp, 5, 12.5);
  EXPECT_EQ(m.header().seq(), 5u);
  const std::vector<Detection> back = DetectionsFromMsg(m);
  ASSERT_EQ(back.size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(back[i].box, dets[i].box);
    EXPECT_EQ(back[i].class_id, dets[i].class_id);
    EXPECT_EQ(back[i].label, dets[i].label);
    EXPECT_EQ(back[i].score, dets[i].score);
  }
  m.detections()[1].w(-1.f);
  ExpectInputError([&] { DetectionsFromMsg(m); }, "Detections.detections[1].box");
  m.detections()[1].w(1.f);
  m.detections()[1].score(std::numeric_limits<float>::quiet_NaN());
  ExpectInputError([&] { DetectionsFromMsg(m); }, "Detections.detections[1].score");
}

KeyframeData TestKeyframe() {
  KeyframeData k;
  k.id = 4;
  k.stamp = Timestamp::FromNanoseconds(1548339824000000000);
  k.world_from_cam = Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY())),
                             Eigen::Vector3d(0.1, 0.2, 0.3));
  k.rgb = cv::Mat(48, 64, CV_8UC3);
  cv::randu(k.rgb, 0, 255);
  k.depth = cv::Mat(48, 64, CV_32FC1);
  cv::randu(k.depth, 0.f, 5.f);
  k.dynamic_mask = cv::Mat::zeros(48, 64, CV_8UC1);
  k.dynamic_mask(cv::Rect(10, 10, 5, 5)).setTo(255);
  k.keypoints = {cv::KeyPoint(1.f, 2.f, 31.f, 45.f, 0.5f, 1),
                 cv::KeyPoint(10.f, 20.f, 37.2f, 90.f, 0.25f, 2)};
  k.keypoint_dynamic = {0, 1};
  Detection d;
  d.box = cv::Rect2f(5, 6, 7, 8);
  d.label = "person";
  d.score = 0.8f;
  k.detections = {d};
  return k;
}

TEST(Convert, KeyframeRoundTrip) {
  const KeyframeData k = TestKeyframe();
  PinholeCamera cam;
  const KeyframeData back = KeyframeFromMsg(KeyframeToMsg(k, TestCamera()), &cam);
  EXPECT_EQ(back.id, 4);
  EXPECT_EQ(back.stamp, k.stamp);
  EXPECT_LT((back.world_from_cam.translation - k.world_from_cam.translation).norm(), 1e-12);
  EXPECT_LT(back.world_from_cam.rotation.angularDistance(k.world_from_cam.rotation), 1e-12);
  EXPECT_EQ(cv::norm(back.rgb, k.rgb, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(back.depth, k.depth, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(back.dynamic_mask, k.dynamic_mask, cv::NORM_INF), 0.0);
  ASSERT_EQ(back.keypoints.size(), 2u);
  EXPECT_EQ(back.keypoints[1].pt, k.keypoints[1].pt);
  EXPECT_EQ(back.keypoints[1].octave, 2);
  EXPECT_EQ(back.keypoint_dynamic, k.keypoint_dynamic);
  ASSERT_EQ(back.detections.size(), 1u);
  EXPECT_EQ(back.detections[0].label, "person");
  EXPECT_EQ(cam.fx, TestCamera().fx);
  EXPECT_FALSE(back.pose_update_only);

  KeyframeData update = k;
  update.pose_update_only = true;
  const msg::Keyframe um = KeyframeToMsg(update, TestCamera());
  EXPECT_TRUE(um.color().data().empty());
  const KeyframeData ub = KeyframeFromMsg(um);
  EXPECT_TRUE(ub.pose_update_only);
  EXPECT_FALSE(ub.removed);
  EXPECT_TRUE(ub.rgb.empty());

  // A culled keyframe: removed travels, no images.
  KeyframeData culled;
  culled.id = 9;
  culled.stamp = k.stamp;
  culled.removed = true;
  const msg::Keyframe cm = KeyframeToMsg(culled, TestCamera());
  EXPECT_TRUE(cm.removed());
  EXPECT_TRUE(cm.pose_update_only());
  EXPECT_TRUE(cm.depth().data().empty());
  const KeyframeData cb = KeyframeFromMsg(cm);
  EXPECT_EQ(cb.id, 9);
  EXPECT_TRUE(cb.removed);
  EXPECT_TRUE(cb.pose_update_only);
}

TEST(Convert, KeyframeInconsistentSamplesAreRejected) {
  const msg::Keyframe good = KeyframeToMsg(TestKeyframe(), TestCamera());
  msg::Keyframe depth16 = good;
  depth16.depth().encoding("16UC1");
  ExpectInputError([&] { KeyframeFromMsg(depth16); }, "Keyframe.depth.encoding");
  msg::Keyframe small_mask = good;
  small_mask.dynamic_mask(ImageToMsg(cv::Mat::zeros(10, 10, CV_8UC1)));
  ExpectInputError([&] { KeyframeFromMsg(small_mask); }, "Keyframe.dynamic_mask");
  msg::Keyframe nan_pose = good;
  nan_pose.world_from_cam().position().x(std::numeric_limits<double>::infinity());
  ExpectInputError([&] { KeyframeFromMsg(nan_pose); }, "Keyframe.world_from_cam.position");
  msg::Keyframe nan_kp = good;
  nan_kp.keypoints()[1].x(std::numeric_limits<float>::quiet_NaN());
  ExpectInputError([&] { KeyframeFromMsg(nan_kp); }, "Keyframe.keypoints[1]");
  msg::Keyframe negative_id = good;
  negative_id.id(-3);
  ExpectInputError([&] { KeyframeFromMsg(negative_id); }, "Keyframe.id");
}

TEST(Convert, TrajectoryAndGroundTruthRoundTrip) {
  std::vector<StampedPose> poses(3);
  for (int i = 0; i < 3; ++i) {
    poses[i].stamp = Timestamp::FromNanoseconds(1000000000LL * i + 33);
    poses[i].world_from_cam.translation = Eigen::Vector3d(i, -i, 0.5 * i);
  }
  const std::vector<StampedPose> back = TrajectoryFromMsg(TrajectoryToMsg(poses, false));
  ASSERT_EQ(back.size(), 3u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(back[i].stamp, poses[i].stamp);
    EXPECT_EQ(back[i].world_from_cam.translation, poses[i].world_from_cam.translation);
  }
  msg::Trajectory bad = TrajectoryToMsg(poses, true);
  bad.poses()[2].world_from_cam().orientation().w(2.0);
  ExpectInputError([&] { TrajectoryFromMsg(bad); },
                   "Trajectory.poses[2].world_from_cam.orientation");

  const StampedPose gt = GroundTruthFromMsg(GroundTruthToMsg(poses[2], 2));
  EXPECT_EQ(gt.stamp, poses[2].stamp);
  EXPECT_EQ(gt.world_from_cam.translation, poses[2].world_from_cam.translation);
}

// StreamStatus.num_frames is uint64 on the wire; the components compare it with int64 counters
// where a negative value means "no end announced". An absurd count must not turn into one.
TEST(Convert, StreamFrameCountSaturatesInsteadOfTurningNegative) {
  msg::StreamStatus status;
  status.num_frames(360);
  EXPECT_EQ(StreamFrameCountFromMsg(status), 360);
  status.num_frames(0);
  EXPECT_EQ(StreamFrameCountFromMsg(status), 0);
  const int64_t max = std::numeric_limits<int64_t>::max();
  status.num_frames(static_cast<uint64_t>(max));
  EXPECT_EQ(StreamFrameCountFromMsg(status), max);
  for (uint64_t absurd : {static_cast<uint64_t>(max) + 1, ~uint64_t{0}}) {
    status.num_frames(absurd);
    EXPECT_EQ(StreamFrameCountFromMsg(status), max) << absurd;
  }
}

}  // namespace
}  // namespace dygslam
