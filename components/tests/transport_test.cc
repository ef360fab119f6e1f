// DDS round trips on loopback (run inside run_in_netns.sh; distinct domain ids per test).
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "components/convert.h"
#include "components/dds/participant.h"
#include "components/dds/pubsub.h"
#include "components/protocol.h"
#include "dygslam_msg/KeyframePubSubTypes.h"
#include "dygslam_msg/RgbdFramePubSubTypes.h"
#include "dygslam_msg/StreamStatusPubSubTypes.h"

namespace dygslam {
namespace {

using namespace std::chrono_literals;

std::shared_ptr<dds::Participant> MakeParticipant(int domain, const std::string& name) {
  dds::ParticipantOptions o;
  o.domain_id = domain;
  o.name = name;
  o.use_xml_profile = false;
  return dds::Participant::Create(o);
}

RgbdFrameData FullSizeFrame(uint64_t seq) {
  RgbdFrameData f;
  f.stamp =
      Timestamp::FromNanoseconds(1548339823898123000LL + static_cast<int64_t>(seq) * 33333333);
  f.seq = seq;
  f.camera.fx = 542.822841;
  f.camera.fy = 542.576870;
  f.camera.cx = 315.593520;
  f.camera.cy = 237.756098;
  f.camera.width = 640;
  f.camera.height = 480;
  f.rgb = cv::Mat(480, 640, CV_8UC3);
  f.depth = cv::Mat(480, 640, CV_16UC1);
  cv::randu(f.rgb, 0, 255);
  cv::randu(f.depth, 0, 60000);
  return f;
}

TEST(Transport, ParticipantOptionsAreChecked) {
  dds::ParticipantOptions o;
  o.domain_id = 300;
  EXPECT_THROW(o.Check(), InvalidOptions);
  o.domain_id = 1;
  o.use_shm = o.use_udp_loopback = false;
  EXPECT_THROW(o.Check(), InvalidOptions);
}

// 30 full-size RGB-D frames between two participants (SHM + 127.0.0.1): every frame arrives,
// bit-identical, in order.
// A component waits for its last status (DONE) to be acknowledged before it goes; the readers
// acknowledge in answer to the writer's heartbeat. With the default heartbeat (3 s) every run's
// end waited 2 s for that; the status writers' short heartbeat answers within a few periods.
TEST(Transport, AStatusSampleIsAcknowledgedWellWithinASecond) {
  const int domain = 104;
  auto pub = MakeParticipant(domain, "test_status_pub");
  auto sub = MakeParticipant(domain, "test_status_sub");
  std::atomic<int> received_here{0}, received_there{0};
  dds::Reader<msg::StreamStatusPubSubType> same(pub, dds::topics::kStreamStatus,
                                                dds::TopicKind::kStreamStatus,
                                                [&](msg::StreamStatus&&) { ++received_here; });
  dds::Reader<msg::StreamStatusPubSubType> other(sub, dds::topics::kStreamStatus,
                                                 dds::TopicKind::kStreamStatus,
                                                 [&](msg::StreamStatus&&) { ++received_there; });
  dds::Writer<msg::StreamStatusPubSubType> writer(pub, dds::topics::kStreamStatus,
                                                  dds::TopicKind::kStreamStatus);
  ASSERT_TRUE(writer.WaitForReaders(2, 10s));
  ASSERT_TRUE(other.WaitForWriters(1, 10s));
  for (int i = 0; i < 3; ++i) {
    ASSERT_TRUE(writer.Write(ToMsg(ComponentStatus::Done(ComponentKind::kSlam, 10 + i))));
    const auto start = std::chrono::steady_clock::now();
    EXPECT_TRUE(writer.WaitForAcknowledgments(1000ms)) << "sample " << i;
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    EXPECT_LT(ms, 1000) << "sample " << i;
    std::this_thread::sleep_for(20ms);
  }
  EXPECT_EQ(received_here.load(), 3);
  EXPECT_EQ(received_there.load(), 3);
}

// A reader knows which writers are matched (a player tells by the mapper's status writer that the
// mapper is there): from the match events, as a writer comes and goes.
TEST(Transport, AReaderKnowsWhichWritersAreMatched) {
  const int domain = 105;
  auto pub = MakeParticipant(domain, "test_presence_pub");
  auto sub = MakeParticipant(domain, "test_presence_sub");
  dds::Reader<msg::StreamStatusPubSubType> reader(
      sub, dds::topics::kStreamStatus, dds::TopicKind::kStreamStatus, [](msg::StreamStatus&&) {});
  auto writer = std::make_unique<dds::Writer<msg::StreamStatusPubSubType>>(
      pub, dds::topics::kStreamStatus, dds::TopicKind::kStreamStatus);
  const WriterGuid guid = writer->guid();
  WriterGuid other = guid;
  other[15] ^= 0xff;
  ASSERT_TRUE(reader.WaitForWriters(1, 10s));
  EXPECT_TRUE(reader.IsMatched(guid));
  EXPECT_FALSE(reader.IsMatched(other));
  writer.reset();
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (reader.IsMatched(guid) && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(10ms);
  EXPECT_FALSE(reader.IsMatched(guid)) << "a deleted writer is unmatched";
}

TEST(Transport, RgbdFramesRoundTripBetweenParticipants) {
  const int domain = 101;
  auto pub = MakeParticipant(domain, "test_pub");
  auto sub = MakeParticipant(domain, "test_sub");
  std::mutex mutex;
  std::condition_variable cv;
  std::vector<RgbdFrameData> received;
  dds::Reader<msg::RgbdFramePubSubType> reader(sub, dds::topics::kRgbdFrame,
                                               dds::TopicKind::kRgbdFrame, [&](msg::RgbdFrame&& m) {
                                                 RgbdFrameData f = RgbdFrameFromMsg(m);
                                                 std::lock_guard<std::mutex> lock(mutex);
                                                 received.push_back(std::move(f));
                                                 cv.notify_all();
                                               });
  dds::Writer<msg::RgbdFramePubSubType> writer(pub, dds::topics::kRgbdFrame,
                                               dds::TopicKind::kRgbdFrame);
  ASSERT_TRUE(writer.WaitForReaders(1, 10s));
  ASSERT_TRUE(reader.WaitForWriters(1, 10s));
  std::vector<RgbdFrameData> sent;
  for (uint64_t i = 0; i < 30; ++i) {
    sent.push_back(FullSizeFrame(i));
    ASSERT_TRUE(writer.Write(RgbdFrameToMsg(sent.back())));
    std::this_thread::sleep_for(33ms);  // 30 Hz
  }
  std::unique_lock<std::mutex> lock(mutex);
  ASSERT_TRUE(cv.wait_for(lock, 20s, [&] { return received.size() >= sent.size(); }))
      << "received " << received.size() << " of " << sent.size();
  for (size_t i = 0; i < sent.size(); ++i) {
    EXPECT_EQ(received[i].seq, sent[i].seq);
    EXPECT_EQ(received[i].stamp, sent[i].stamp);
    EXPECT_EQ(cv::norm(received[i].rgb, sent[i].rgb, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(received[i].depth, sent[i].depth, cv::NORM_INF), 0.0);
  }
}

KeyframeData SmallKeyframe(int64_t id) {
  KeyframeData k;
  k.id = id;
  k.stamp = Timestamp::FromNanoseconds(1000000000LL * (id + 1));
  k.world_from_cam.translation = Eigen::Vector3d(0.1 * id, 0, 0);
  k.rgb = cv::Mat(48, 64, CV_8UC3, cv::Scalar(id, 2, 3));
  k.depth = cv::Mat(48, 64, CV_32FC1, cv::Scalar(1.5f));
  k.dynamic_mask = cv::Mat::zeros(48, 64, CV_8UC1);
  return k;
}

// A late mapper's keyframe reader: the ids of the keyframe messages it receives, in order.
struct KeyframeIds {
  explicit KeyframeIds(std::shared_ptr<dds::Participant> participant)
      : reader(std::move(participant), dds::topics::kKeyframe, dds::TopicKind::kKeyframe,
               [this](msg::Keyframe&& m) {
                 const KeyframeData k = KeyframeFromMsg(m);
                 std::lock_guard<std::mutex> lock(mutex);
                 ids.push_back(k.id);
                 cv.notify_all();
               }) {}
  std::mutex mutex;
  std::condition_variable cv;
  std::vector<int64_t> ids;                     // guarded by mutex
  dds::Reader<msg::KeyframePubSubType> reader;  // last: its callback uses the members above
};

// Keyframes are transient-local with a bounded history: a mapper that subscribes after all
// keyframes were published still receives every one of them, in order (fewer than
// kKeyframeHistoryDepth here).
TEST(Transport, LateKeyframeSubscriberReceivesHistory) {
  const int domain = 102;
  PinholeCamera camera;
  camera.fx = camera.fy = 50;
  camera.cx = 32;
  camera.cy = 24;
  camera.width = 64;
  camera.height = 48;
  auto pub = MakeParticipant(domain, "test_slam");
  dds::Writer<msg::KeyframePubSubType> writer(pub, dds::topics::kKeyframe,
                                              dds::TopicKind::kKeyframe);
  const int kCount = 25;
  for (int i = 0; i < kCount; ++i)
    ASSERT_TRUE(writer.Write(KeyframeToMsg(SmallKeyframe(i), camera)));

  std::this_thread::sleep_for(300ms);
  auto sub = MakeParticipant(domain, "test_late_mapper");
  KeyframeIds received(sub);
  std::unique_lock<std::mutex> lock(received.mutex);
  std::vector<int64_t>& ids = received.ids;
  std::condition_variable& cv = received.cv;
  ASSERT_TRUE(cv.wait_for(lock, 20s, [&] { return ids.size() >= kCount; }))
      << "late subscriber got " << ids.size() << " of " << kCount;
  for (int i = 0; i < kCount; ++i) EXPECT_EQ(ids[i], i);
}

// The bound: after more than kKeyframeHistoryDepth messages, a late subscriber receives exactly
// the newest kKeyframeHistoryDepth, in order (the writer's history no longer grows with the run).
TEST(Transport, LateKeyframeSubscriberReceivesBoundedHistory) {
  const int domain = 103;
  PinholeCamera camera;
  camera.fx = camera.fy = 50;
  camera.cx = 32;
  camera.cy = 24;
  camera.width = 64;
  camera.height = 48;
  auto pub = MakeParticipant(domain, "test_slam");
  dds::Writer<msg::KeyframePubSubType> writer(pub, dds::topics::kKeyframe,
                                              dds::TopicKind::kKeyframe);
  const int kCount = dds::kKeyframeHistoryDepth + 40;
  for (int i = 0; i < kCount; ++i) {
    KeyframeData k = SmallKeyframe(i);
    k.pose_update_only = i % 3 != 0;  // mixed sizes, like new keyframes + local-BA updates
    ASSERT_TRUE(writer.Write(KeyframeToMsg(k, camera))) << "message " << i;
  }
  std::this_thread::sleep_for(300ms);
  auto sub = MakeParticipant(domain, "test_late_mapper");
  KeyframeIds received(sub);
  std::unique_lock<std::mutex> lock(received.mutex);
  std::vector<int64_t>& ids = received.ids;
  std::condition_variable& cv = received.cv;
  ASSERT_TRUE(cv.wait_for(lock, 20s, [&] { return ids.size() >= dds::kKeyframeHistoryDepth; }))
      << "late subscriber got " << ids.size() << " of " << dds::kKeyframeHistoryDepth;
  cv.wait_for(lock, 500ms);  // nothing more arrives
  ASSERT_EQ(ids.size(), static_cast<size_t>(dds::kKeyframeHistoryDepth));
  for (int i = 0; i < dds::kKeyframeHistoryDepth; ++i) {
    EXPECT_EQ(ids[i], kCount - dds::kKeyframeHistoryDepth + i);
  }
}

}  // namespace
}  // namespace dygslam
