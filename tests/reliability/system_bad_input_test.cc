// Bad input into the System (core/system): every case gives a clear InputError / InvalidOptions
// or a frame without a pose -- never a crash, never a made-up pose. Real frames from
// bonn_crowd_part (people-free first 60 frames).
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/config/settings.h"
#include "core/io/dataset.h"
#include "core/system/system.h"
#include "run/settings_table.h"
#include "run/system_config.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {

constexpr int kFrames = 45;

struct Frames {
  std::vector<cv::Mat> rgb, depth;
  std::vector<Timestamp> stamps;
};

// Loads the first kFrames frames once for the whole suite.
const Frames& BonnFrames(const std::string& dir) {
  static Frames frames;
  if (!frames.rgb.empty()) return frames;
  const RgbdDataset d = RgbdDataset::Open(dir);
  for (size_t i = 0; i < static_cast<size_t>(kFrames) && i < d.size(); ++i) {
    frames.rgb.push_back(d.LoadRgb(i, 640, 480));
    frames.depth.push_back(d.LoadDepth(i, 640, 480));
    frames.stamps.push_back(d.frame(i).rgb_stamp);
  }
  return frames;
}

SystemOptions BonnOptions(FilterMode mode = FilterMode::kNone) {
  const Settings settings =
      LoadSettings(std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/bonn.yaml");
  SystemOptions o = SystemOptionsFromSettings(settings);
  o.filter.mode = mode;
  o.deterministic = true;
  return o;
}

// Asserts that `fn` throws E whose message contains every needle.
template <class E, class Fn>
void ExpectThrowNaming(Fn fn, const std::vector<std::string>& needles) {
  try {
    fn();
    ADD_FAILURE() << "expected an exception naming " << needles.front();
  } catch (const E& e) {
    for (const std::string& n : needles) {
      EXPECT_NE(std::string(e.what()).find(n), std::string::npos)
          << "message '" << e.what() << "' does not name '" << n << "'";
    }
  }
}

double TranslationError(const Rigid3d& a, const Rigid3d& b) {
  return (a.translation - b.translation).norm();
}
double RotationErrorDeg(const Rigid3d& a, const Rigid3d& b) {
  return RotationAngle(a.rotation.conjugate() * b.rotation) * 180.0 / M_PI;
}

// Poses of a clean deterministic run (the reference for the runs with corrupted frames).
const std::vector<FrameResult>& ReferenceRun(const Frames& f) {
  static std::vector<FrameResult> results;
  if (!results.empty()) return results;
  System system(BonnOptions());
  for (size_t i = 0; i < f.rgb.size(); ++i) {
    results.push_back(system.FeedRgbdFrame(f.rgb[i], f.depth[i], f.stamps[i]));
  }
  system.Shutdown();
  return results;
}

class SystemBadInput : public ::testing::Test {
 protected:
  void SetUp() override {
    DYGSLAM_REQUIRE_DATASET(dir, "bonn_crowd_part");
    frames_ = &BonnFrames(dir);
    ASSERT_EQ(frames_->rgb.size(), static_cast<size_t>(kFrames));
  }
  const Frames& f() const { return *frames_; }
  const Frames* frames_ = nullptr;
};

TEST_F(SystemBadInput, ReferenceRunTracksEveryFrame) {
  // Sanity check of the reference the other tests compare against.
  const auto& ref = ReferenceRun(f());
  for (size_t i = 0; i < ref.size(); ++i) {
    EXPECT_TRUE(HasPose(ref[i].state)) << "frame " << i << " " << ToString(ref[i].state);
  }
}

TEST_F(SystemBadInput, DepthAllZeroFromTheStartNeverInitialises) {
  System system(BonnOptions());
  const cv::Mat zero16 = cv::Mat::zeros(480, 640, CV_16UC1);
  const cv::Mat zero32 = cv::Mat::zeros(480, 640, CV_32FC1);
  for (int i = 0; i < 6; ++i) {
    const FrameResult r = system.FeedRgbdFrame(f().rgb[i], i % 2 ? zero32 : zero16, f().stamps[i]);
    EXPECT_FALSE(HasPose(r.state)) << "frame " << i << ": " << ToString(r.state);
    EXPECT_FALSE(r.world_from_cam.has_value()) << "frame " << i;
    EXPECT_FALSE(r.is_keyframe);
  }
  system.Shutdown();
  EXPECT_TRUE(system.Trajectory().empty());
  EXPECT_TRUE(system.KeyframeTrajectory().empty());
}

TEST_F(SystemBadInput, DepthInvalidEverywhereNaNInfNegativeNeverInitialises) {
  System system(BonnOptions());
  cv::Mat bad(480, 640, CV_32FC1);
  for (int y = 0; y < bad.rows; ++y) {
    for (int x = 0; x < bad.cols; ++x) {
      const int k = (x + y) % 4;
      bad.at<float>(y, x) = k == 0   ? std::numeric_limits<float>::quiet_NaN()
                            : k == 1 ? std::numeric_limits<float>::infinity()
                            : k == 2 ? -1.5f
                                     : -std::numeric_limits<float>::infinity();
    }
  }
  for (int i = 0; i < 3; ++i) {
    const FrameResult r = system.FeedRgbdFrame(f().rgb[i], bad, f().stamps[i]);
    EXPECT_FALSE(HasPose(r.state)) << ToString(r.state);
    EXPECT_FALSE(r.world_from_cam.has_value());
  }
}

// Depth drops out (all zero) for a stretch after initialisation: each of those frames either has
// no pose or a pose that agrees with the clean run; tracking goes on afterwards.
TEST_F(SystemBadInput, DepthDropoutMidRunGivesNoWrongPose) {
  const auto& ref = ReferenceRun(f());
  System system(BonnOptions());
  const cv::Mat zero = cv::Mat::zeros(480, 640, CV_16UC1);
  int dropout_with_pose = 0;
  for (int i = 0; i < kFrames; ++i) {
    const bool dropout = i >= 15 && i < 25;
    const FrameResult r =
        system.FeedRgbdFrame(f().rgb[i], dropout ? zero : f().depth[i], f().stamps[i]);
    EXPECT_EQ(r.world_from_cam.has_value(), HasPose(r.state));
    if (!r.world_from_cam) continue;
    dropout_with_pose += dropout ? 1 : 0;
    ASSERT_TRUE(ref[i].world_from_cam.has_value());
    EXPECT_LT(TranslationError(*r.world_from_cam, *ref[i].world_from_cam), 0.05) << "frame " << i;
    EXPECT_LT(RotationErrorDeg(*r.world_from_cam, *ref[i].world_from_cam), 2.0) << "frame " << i;
  }
  // After the dropout the system is tracking again.
  for (int i = 0; i < 1; ++i) {
    const FrameResult r = system.FeedRgbdFrame(
        f().rgb[kFrames - 1], f().depth[kFrames - 1],
        Timestamp::FromNanoseconds(f().stamps.back().nanoseconds() + 33000000));
    EXPECT_TRUE(HasPose(r.state)) << ToString(r.state);
  }
  system.Shutdown();
  for (const StampedPose& p : system.Trajectory()) EXPECT_TRUE(p.world_from_cam.AllFinite());
  RecordProperty("dropout_frames_with_pose", dropout_with_pose);
}

// A missing depth frame (empty Mat, e.g. a dropped DDS sample) is a clear error for that frame;
// the system keeps its state and tracks the next frames.
TEST_F(SystemBadInput, MissingDepthFrameIsAnErrorAndTrackingContinues) {
  System system(BonnOptions());
  for (int i = 0; i < 10; ++i) {
    if (i == 5) {
      ExpectThrowNaming<InputError>(
          [&] { system.FeedRgbdFrame(f().rgb[i], cv::Mat(), f().stamps[i]); }, {"depth image"});
      continue;
    }
    const FrameResult r = system.FeedRgbdFrame(f().rgb[i], f().depth[i], f().stamps[i]);
    EXPECT_TRUE(HasPose(r.state)) << "frame " << i << " " << ToString(r.state);
  }
}

TEST_F(SystemBadInput, WrongSizesAndEncodingsNameTheImage) {
  System system(BonnOptions());
  const Timestamp t = f().stamps[0];
  cv::Mat small_rgb(240, 320, CV_8UC3, cv::Scalar(1, 2, 3));
  ExpectThrowNaming<InputError>([&] { system.FeedRgbdFrame(small_rgb, f().depth[0], t); },
                                {"rgb image", "320x240", "640x480"});
  cv::Mat small_depth(240, 320, CV_16UC1, cv::Scalar(5000));
  ExpectThrowNaming<InputError>([&] { system.FeedRgbdFrame(f().rgb[0], small_depth, t); },
                                {"depth image", "size"});
  cv::Mat rgb16(480, 640, CV_16UC3, cv::Scalar(1, 2, 3));
  ExpectThrowNaming<InputError>([&] { system.FeedRgbdFrame(rgb16, f().depth[0], t); },
                                {"rgb image", "type"});
  cv::Mat rgba(480, 640, CV_8UC4, cv::Scalar(1, 2, 3, 4));
  ExpectThrowNaming<InputError>([&] { system.FeedRgbdFrame(rgba, f().depth[0], t); },
                                {"rgb image"});
  cv::Mat depth8(480, 640, CV_8UC1, cv::Scalar(5));
  ExpectThrowNaming<InputError>([&] { system.FeedRgbdFrame(f().rgb[0], depth8, t); },
                                {"depth image"});
  cv::Mat depth_2ch(480, 640, CV_16UC2, cv::Scalar(5000, 5000));
  ExpectThrowNaming<InputError>([&] { system.FeedRgbdFrame(f().rgb[0], depth_2ch, t); },
                                {"depth image"});
  ExpectThrowNaming<InputError>([&] { system.FeedRgbdFrame(cv::Mat(), f().depth[0], t); },
                                {"rgb image"});
  // Masks must match the image (a wrongly sized mask would be silently rescaled).
  cv::Mat small_mask = cv::Mat::zeros(240, 320, CV_8UC1);
  ExpectThrowNaming<InputError>(
      [&] { system.FeedRgbdFrame(f().rgb[0], f().depth[0], t, small_mask); }, {"mask", "320x240"});
  cv::Mat float_mask = cv::Mat::zeros(480, 640, CV_32FC1);
  ExpectThrowNaming<InputError>(
      [&] { system.FeedRgbdFrame(f().rgb[0], f().depth[0], t, float_mask); }, {"mask"});
  // None of the rejected frames consumed the stamp: the same frame is accepted afterwards.
  const FrameResult r = system.FeedRgbdFrame(f().rgb[0], f().depth[0], t);
  EXPECT_TRUE(HasPose(r.state)) << ToString(r.state);
}

TEST_F(SystemBadInput, TimestampBackwardsOrRepeatedIsAnErrorNamingBothStamps) {
  System system(BonnOptions());
  for (int i = 0; i < 5; ++i)
    ASSERT_TRUE(HasPose(system.FeedRgbdFrame(f().rgb[i], f().depth[i], f().stamps[i]).state));
  // Jump backwards (a replayed or looped stream) and a repeated stamp.
  ExpectThrowNaming<InputError>(
      [&] { system.FeedRgbdFrame(f().rgb[5], f().depth[5], f().stamps[2]); },
      {f().stamps[2].ToString(), f().stamps[4].ToString(), "not after"});
  ExpectThrowNaming<InputError>(
      [&] { system.FeedRgbdFrame(f().rgb[5], f().depth[5], f().stamps[4]); },
      {f().stamps[4].ToString(), "not after"});
  // The rejected frames left no trace: the trajectory has exactly the 5 accepted frames and the
  // next frame in order is tracked.
  const FrameResult r = system.FeedRgbdFrame(f().rgb[5], f().depth[5], f().stamps[5]);
  EXPECT_TRUE(HasPose(r.state));
  system.Shutdown();
  const auto trajectory = system.Trajectory();
  ASSERT_EQ(trajectory.size(), 6u);
  for (size_t i = 1; i < trajectory.size(); ++i)
    EXPECT_LT(trajectory[i - 1].stamp, trajectory[i].stamp);
}

TEST_F(SystemBadInput, BlackAndSaturatedFramesGiveNoPose) {
  System system(BonnOptions());
  const cv::Mat black = cv::Mat::zeros(480, 640, CV_8UC3);
  const cv::Mat white(480, 640, CV_8UC3, cv::Scalar(255, 255, 255));
  FrameResult r = system.FeedRgbdFrame(black, f().depth[0], f().stamps[0]);
  EXPECT_FALSE(HasPose(r.state));
  EXPECT_EQ(r.num_features, 0);
  for (int i = 1; i < 8; ++i)
    ASSERT_TRUE(HasPose(system.FeedRgbdFrame(f().rgb[i], f().depth[i], f().stamps[i]).state));
  // Camera covered / blinded after initialisation: lost, no pose, and tracking comes back.
  r = system.FeedRgbdFrame(white, f().depth[8], f().stamps[8]);
  EXPECT_EQ(r.state, TrackingState::kLost);
  EXPECT_FALSE(r.world_from_cam.has_value());
  r = system.FeedRgbdFrame(black, f().depth[9], f().stamps[9]);
  EXPECT_EQ(r.state, TrackingState::kLost);
  bool recovered = false;
  for (int i = 10; i < 20 && !recovered; ++i) {
    r = system.FeedRgbdFrame(f().rgb[i], f().depth[i], f().stamps[i]);
    recovered = HasPose(r.state);
    if (recovered) {
      // Reported as a relocalisation, with a pose that agrees with the clean run.
      EXPECT_EQ(r.state, TrackingState::kRelocalized) << ToString(r.state);
      const auto& ref = ReferenceRun(f());
      EXPECT_LT(TranslationError(*r.world_from_cam, *ref[i].world_from_cam), 0.05);
    }
  }
  EXPECT_TRUE(recovered) << "no relocalisation after the blind frames";
}

// Detections handed in from outside (DDS detector) with absurd values must not crash the filter
// or the static top-up; the frame is still tracked.
TEST_F(SystemBadInput, AbsurdExternalDetectionsDoNotCrash) {
  System system(BonnOptions(FilterMode::kFull));
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  std::vector<Detection> absurd(6);
  absurd[0].box = cv::Rect2f(nan, nan, nan, nan);
  absurd[1].box = cv::Rect2f(-1e9f, -1e9f, 2e9f, 2e9f);
  absurd[2].box = cv::Rect2f(1e30f, 1e30f, inf, inf);
  absurd[3].box = cv::Rect2f(100, 100, -50, -50);
  absurd[4].box = cv::Rect2f(700, 500, 10, 10);
  absurd[5].box = cv::Rect2f(0, 0, 0, 0);
  for (size_t k = 0; k < absurd.size(); ++k) {
    absurd[k].label = "person";
    absurd[k].score = k == 0 ? nan : 0.9f;
  }
  for (int i = 0; i < 6; ++i) {
    FrameResult r;
    try {
      r = system.FeedRgbdFrame(f().rgb[i], f().depth[i], f().stamps[i], cv::Mat(), &absurd);
    } catch (const InputError& e) {
      // A clear rejection naming the detections is acceptable too.
      EXPECT_NE(std::string(e.what()).find("detection"), std::string::npos) << e.what();
      continue;
    }
    EXPECT_EQ(r.world_from_cam.has_value(), HasPose(r.state));
    if (r.world_from_cam) {
      EXPECT_TRUE(r.world_from_cam->AllFinite());
    }
  }
}

TEST(SystemBadOptions, NonFiniteOptionsAreRejectedAtConstruction) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  struct Case {
    const char* name;
    std::function<void(SystemOptions*)> set;
  };
  const std::vector<Case> cases = {
      {"Camera.fx", [&](SystemOptions* o) { o->camera.fx = nan; }},
      {"Camera.cy", [&](SystemOptions* o) { o->camera.cy = inf; }},
      {"Camera.k1", [&](SystemOptions* o) { o->camera.k1 = nan; }},
      {"Camera.width", [&](SystemOptions* o) { o->camera.width = 0; }},
      {"Camera.bf", [&](SystemOptions* o) { o->sensor.bf = nan; }},
      {"DepthMapFactor", [&](SystemOptions* o) { o->sensor.depth_map_factor = -inf; }},
      {"ThDepth", [&](SystemOptions* o) { o->sensor.th_depth = nan; }},
      {"ORBextractor.scaleFactor", [&](SystemOptions* o) { o->orb.scale_factor = nan; }},
      {"Tracking.motion_radius_px", [&](SystemOptions* o) { o->tracking.motion_radius_px = nan; }},
      {"Tracking.ref_ratio", [&](SystemOptions* o) { o->tracking.ref_ratio = nan; }},
      {"LocalMapping.redundancy_ratio",
       [&](SystemOptions* o) { o->local_mapping.redundancy_ratio = nan; }},
      {"DynamicFilter.c1", [&](SystemOptions* o) { o->filter.c1 = nan; }},
      {"DynamicFilter.threshold", [&](SystemOptions* o) { o->filter.threshold = nan; }},
      {"DynamicFilter.p_init", [&](SystemOptions* o) { o->filter.p_init = inf; }},
      // Used only when a keyframe is made: must still fail at construction, not mid-run.
      {"DynamicMask", [&](SystemOptions* o) { o->dynamic_mask.depth_band = nan; }},
  };
  for (const Case& c : cases) {
    SystemOptions o;
    o.camera.fx = o.camera.fy = 500;
    o.camera.cx = 320;
    o.camera.cy = 240;
    o.filter.mode = FilterMode::kNone;
    ASSERT_NO_THROW(o.Check());
    c.set(&o);
    ExpectThrowNaming<InvalidOptions>([&] { System s(o); }, {c.name});
  }
}

}  // namespace
}  // namespace dygslam
