// Incoming DDS samples at the wire level: raw serialized payloads (as a DataReader receives them
// from any participant on the domain) through the generated deserialize() and the convert.h
// decoders. Truncated payloads, absurd sequence lengths, inconsistent image sizes and absurd
// values are rejected with a reason; nothing crashes or allocates without bound.
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <limits>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "components/convert.h"
#include "fuzz/dds_decoders.h"

namespace dygslam {
namespace {
using fuzz::DecodeSample;
using fuzz::DecodeStatus;
using fuzz::SampleKind;

PinholeCamera Camera(int w, int h) {
  PinholeCamera c;
  c.fx = c.fy = 50;
  c.cx = w / 2.0;
  c.cy = h / 2.0;
  c.width = w;
  c.height = h;
  return c;
}

msg::RgbdFrame Frame(int w = 8, int h = 6) {
  RgbdFrameData f;
  f.stamp = Timestamp::FromNanoseconds(1548339823898123000);
  f.camera = Camera(w, h);
  f.rgb = cv::Mat(h, w, CV_8UC3, cv::Scalar(10, 20, 30));
  f.depth = cv::Mat(h, w, CV_16UC1, cv::Scalar(5000));
  return RgbdFrameToMsg(f);
}

std::vector<uint8_t> Bytes(const msg::RgbdFrame& m) {
  return fuzz::Serialize<msg::RgbdFramePubSubType>(m);
}

DecodeStatus StatusOf(SampleKind kind, const std::vector<uint8_t>& b) {
  return DecodeSample(kind, b.data(), b.size()).status;
}

// Offset of the first little-endian uint32 `value` followed by `next` bytes equal to `fill`.
size_t FindLength(const std::vector<uint8_t>& b, uint32_t value, uint8_t fill) {
  for (size_t i = 0; i + 5 <= b.size(); ++i) {
    uint32_t v;
    std::memcpy(&v, b.data() + i, 4);
    if (v == value && b[i + 4] == fill) return i;
  }
  return std::string::npos;
}

long MaxRssKb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss;
}

std::vector<std::pair<SampleKind, std::vector<uint8_t>>> ValidSamples() {
  std::vector<std::pair<SampleKind, std::vector<uint8_t>>> out;
  out.emplace_back(SampleKind::kRgbdFrame, Bytes(Frame()));
  std::vector<Detection> dets(2);
  dets[0].box = cv::Rect2f(1, 2, 3, 4);
  dets[0].label = "person";
  dets[0].score = 0.9f;
  out.emplace_back(SampleKind::kDetections,
                   fuzz::Serialize<msg::DetectionsPubSubType>(
                       DetectionsToMsg(dets, Timestamp::FromNanoseconds(5), 1)));
  const Rigid3d pose(Eigen::Quaterniond(0.9, 0.1, -0.2, 0.3), Eigen::Vector3d(1, -2, 0.5));
  msg::CameraPose cp;
  cp.has_pose(true);
  cp.world_from_cam(PoseToMsg(pose));
  out.emplace_back(SampleKind::kCameraPose, fuzz::Serialize<msg::CameraPosePubSubType>(cp));
  KeyframeData k;
  k.id = 4;
  k.world_from_cam = pose;
  k.rgb = cv::Mat(6, 8, CV_8UC3, cv::Scalar(1, 2, 3));
  k.depth = cv::Mat(6, 8, CV_32FC1, cv::Scalar(2.0));
  k.dynamic_mask = cv::Mat::zeros(6, 8, CV_8UC1);
  k.keypoints = {cv::KeyPoint(1, 2, 7, 30, 0.5f, 1), cv::KeyPoint(5, 4, 7, 60, 0.2f, 0)};
  k.keypoint_dynamic = {0, 1};
  k.detections = dets;
  out.emplace_back(SampleKind::kKeyframe,
                   fuzz::Serialize<msg::KeyframePubSubType>(KeyframeToMsg(k, Camera(8, 6))));
  out.emplace_back(SampleKind::kGroundTruth,
                   fuzz::Serialize<msg::GroundTruthPosePubSubType>(
                       GroundTruthToMsg(StampedPose{Timestamp(), pose}, 2)));
  out.emplace_back(
      SampleKind::kTrajectory,
      fuzz::Serialize<msg::TrajectoryPubSubType>(TrajectoryToMsg(
          {{Timestamp::FromNanoseconds(1), pose}, {Timestamp::FromNanoseconds(2), pose}}, false)));
  msg::StreamStatus s;
  s.source("player");
  out.emplace_back(SampleKind::kStreamStatus, fuzz::Serialize<msg::StreamStatusPubSubType>(s));
  return out;
}

TEST(DdsWire, ValidSamplesOfEveryTypeDecode) {
  for (const auto& [kind, bytes] : ValidSamples()) {
    ASSERT_FALSE(bytes.empty()) << fuzz::ToString(kind);
    const auto r = DecodeSample(kind, bytes.data(), bytes.size());
    EXPECT_EQ(r.status, DecodeStatus::kOk) << fuzz::ToString(kind) << ": " << r.message;
  }
}

TEST(DdsWire, EveryTruncationIsRejectedOrConsistent) {
  for (const auto& [kind, bytes] : ValidSamples()) {
    int rejected = 0;
    for (size_t n = 0; n < bytes.size(); ++n) {
      // DecodeSample aborts the test (std::logic_error) if a decoder accepts inconsistent data.
      const auto r = DecodeSample(kind, bytes.data(), n);
      rejected += r.status != DecodeStatus::kOk;
    }
    // Only cuts in trailing padding may still decode.
    EXPECT_GE(rejected, static_cast<int>(bytes.size()) - 4) << fuzz::ToString(kind);
  }
}

TEST(DdsWire, AbsurdSequenceLengthsAreRejectedWithoutAllocating) {
  const std::vector<uint8_t> good = Bytes(Frame());
  const size_t at = FindLength(good, 8 * 6 * 3, 10);  // color.data length, then the pixel bytes
  ASSERT_NE(at, std::string::npos);
  const long rss_before = MaxRssKb();
  for (uint32_t length : {0xffffffffu, 0x80000000u, 0x10000000u, 8u * 6 * 3 + 1}) {
    std::vector<uint8_t> bad = good;
    std::memcpy(bad.data() + at, &length, 4);
    const auto r = DecodeSample(SampleKind::kRgbdFrame, bad.data(), bad.size());
    EXPECT_NE(r.status, DecodeStatus::kOk) << "length " << length;
  }
  // A 4 GiB claim must not be honoured by allocating it.
  EXPECT_LT(MaxRssKb() - rss_before, 200 * 1024) << "decoding an absurd length allocated memory";
  // Same for a string length (the frame_id right after the stamp).
  std::vector<uint8_t> bad = good;
  const uint32_t huge = 0xfffffff0u;
  std::memcpy(bad.data() + 4 + 8, &huge, 4);  // encapsulation(4) + Time(8) -> frame_id length
  EXPECT_NE(StatusOf(SampleKind::kRgbdFrame, bad), DecodeStatus::kOk);
}

TEST(DdsWire, InconsistentImageSizesNameTheField) {
  struct Case {
    const char* field;
    std::function<void(msg::RgbdFrame*)> edit;
  };
  const std::vector<Case> cases = {
      {"RgbdFrame.color.data", [](msg::RgbdFrame* m) { m->color().data().resize(8 * 6 * 3 - 1); }},
      {"RgbdFrame.depth.data", [](msg::RgbdFrame* m) { m->depth().data().resize(8 * 6 * 2 + 2); }},
      {"RgbdFrame.color",
       [](msg::RgbdFrame* m) {  // consistent image, but not the camera's size
         m->color().width(6);
         m->color().step(18);
         m->color().data().resize(6 * 6 * 3);
       }},
      {"RgbdFrame.depth.step", [](msg::RgbdFrame* m) { m->depth().step(15); }},
      {"RgbdFrame.color.width", [](msg::RgbdFrame* m) { m->color().width(0xffffffffu); }},
      {"RgbdFrame.color.height", [](msg::RgbdFrame* m) { m->color().height(0); }},
      {"RgbdFrame.depth.width",
       [](msg::RgbdFrame* m) {  // 16384 x 16384 x 4 bytes: would be 1 GiB
         m->depth().width(16385);
         m->depth().height(16384);
         m->depth().encoding("32FC1");
         m->depth().step(16385 * 4);
       }},
      {"RgbdFrame.depth.encoding", [](msg::RgbdFrame* m) { m->depth().encoding("bgr8"); }},
      {"RgbdFrame.color.encoding", [](msg::RgbdFrame* m) { m->color().encoding("yuv422"); }},
      {"RgbdFrame.camera.fx",
       [](msg::RgbdFrame* m) { m->camera().fx(std::numeric_limits<double>::quiet_NaN()); }},
      {"RgbdFrame.camera.fy", [](msg::RgbdFrame* m) { m->camera().fy(-1); }},
      {"RgbdFrame.camera.depth_scale",
       [](msg::RgbdFrame* m) { m->camera().depth_scale(std::numeric_limits<double>::infinity()); }},
      {"RgbdFrame.camera.depth_scale", [](msg::RgbdFrame* m) { m->camera().depth_scale(0); }},
      {"RgbdFrame.header.stamp.nanosec",
       [](msg::RgbdFrame* m) { m->header().stamp().nanosec(1000000000u); }},
  };
  for (const Case& c : cases) {
    msg::RgbdFrame m = Frame();
    c.edit(&m);
    const std::vector<uint8_t> bytes = Bytes(m);
    const auto r = DecodeSample(SampleKind::kRgbdFrame, bytes.data(), bytes.size());
    EXPECT_EQ(r.status, DecodeStatus::kRejectedContent) << c.field << ": " << r.message;
    EXPECT_NE(r.message.find(c.field), std::string::npos)
        << "'" << r.message << "' does not name " << c.field;
  }
}

TEST(DdsWire, AbsurdPosesDetectionsAndKeyframesAreRejected) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  msg::CameraPose cp;
  cp.has_pose(true);
  cp.world_from_cam().orientation().w(1);
  cp.world_from_cam().position().x(nan);
  auto b = fuzz::Serialize<msg::CameraPosePubSubType>(cp);
  EXPECT_EQ(StatusOf(SampleKind::kCameraPose, b), DecodeStatus::kRejectedContent);
  cp.world_from_cam().position().x(0);
  cp.world_from_cam().orientation().w(2);  // not a rotation
  b = fuzz::Serialize<msg::CameraPosePubSubType>(cp);
  EXPECT_EQ(StatusOf(SampleKind::kCameraPose, b), DecodeStatus::kRejectedContent);

  std::vector<Detection> dets(1);
  dets[0].box = cv::Rect2f(1, 2, 3, 4);
  msg::Detections dm = DetectionsToMsg(dets, Timestamp(), 0);
  dm.detections()[0].w(std::numeric_limits<float>::infinity());
  b = fuzz::Serialize<msg::DetectionsPubSubType>(dm);
  EXPECT_EQ(StatusOf(SampleKind::kDetections, b), DecodeStatus::kRejectedContent);

  msg::Trajectory t = TrajectoryToMsg({{Timestamp(), Rigid3d()}}, true);
  t.poses()[0].world_from_cam().orientation().w(0);
  b = fuzz::Serialize<msg::TrajectoryPubSubType>(t);
  EXPECT_EQ(StatusOf(SampleKind::kTrajectory, b), DecodeStatus::kRejectedContent);
}

// fastcdr bounds a sequence length by the bytes left in the payload, but resizes the vector
// before decoding the elements: a payload of B bytes can make the reader allocate about
// B x sizeof(element) (here Detection2D). Characterises that amplification for a 1 MiB sample.
TEST(DdsWire, SequenceLengthClaimsAllocateAtMostElementSizeTimesPayload) {
  std::vector<Detection> one(1);
  one[0].box = cv::Rect2f(1.25f, 2, 3, 4);
  std::vector<uint8_t> b =
      fuzz::Serialize<msg::DetectionsPubSubType>(DetectionsToMsg(one, Timestamp(), 0));
  const float x = 1.25f;
  size_t at = std::string::npos;
  for (size_t i = 0; i + 8 <= b.size(); ++i) {
    uint32_t v;
    std::memcpy(&v, b.data() + i, 4);
    if (v == 1 && std::memcmp(b.data() + i + 4, &x, 4) == 0) at = i;
  }
  ASSERT_NE(at, std::string::npos);
  const size_t payload = 1u << 20;
  b.resize(payload, 0);
  const uint32_t claim = static_cast<uint32_t>(payload - at - 4);
  std::memcpy(b.data() + at, &claim, 4);
  const long before = MaxRssKb();
  const auto r = DecodeSample(SampleKind::kDetections, b.data(), b.size());
  const long grown_kb = MaxRssKb() - before;
  EXPECT_NE(r.status, DecodeStatus::kOk);
  RecordProperty("rss_growth_kb_for_1MiB_payload", static_cast<int>(grown_kb));
  std::printf("sizeof(msg::Detection2D) = %zu, max RSS growth for a 1 MiB sample: %ld KiB\n",
              sizeof(msg::Detection2D), grown_kb);
  EXPECT_LT(grown_kb, 200 * 1024);
}

// fastcdr throws BadParamException for a boolean byte other than 0/1; the generated
// deserialize() does not catch it (only NotEnoughMemoryException). Pins that behaviour: any
// DataReader taking these types must catch eprosima::fastcdr::exception::Exception, or a single
// malformed sample from any participant on the domain terminates the process.
TEST(DdsWire, BadBooleanByteEscapesGeneratedDeserialize) {
  msg::CameraPose cp;
  cp.has_pose(true);
  cp.is_keyframe(true);
  cp.world_from_cam().orientation().w(1);
  std::vector<uint8_t> b = fuzz::Serialize<msg::CameraPosePubSubType>(cp);
  // encapsulation(4) + Header{Time(8), frame_id(4 + len + pad), seq(8)} + tracking_state(1) +
  // has_pose(1)
  const std::string frame_id = cp.header().frame_id();
  size_t at = 4 + 8 + 4 + frame_id.size() + 1;
  at = (at - 4 + 7) / 8 * 8 + 4 + 8;  // seq is 8-aligned relative to the CDR origin
  at += 1;                            // has_pose after tracking_state
  ASSERT_LT(at, b.size());
  ASSERT_EQ(b[at], 1);
  b[at] = 2;
  const auto r = DecodeSample(SampleKind::kCameraPose, b.data(), b.size());
  EXPECT_EQ(r.status, DecodeStatus::kCdrException) << r.message;
}

}  // namespace
}  // namespace dygslam
