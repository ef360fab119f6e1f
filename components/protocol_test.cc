// The component protocol without DDS: status messages both ways, what is refused, writer
// ownership and the bounded holding of samples that arrive before their writer's announcement.
#include "components/protocol.h"

#include <gtest/gtest.h>

#include "core/base/error.h"

namespace dygslam {
namespace {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

WriterGuid Guid(uint8_t participant, uint8_t entity) {
  WriterGuid g{};
  for (size_t i = 0; i < 12; ++i) g[i] = static_cast<uint8_t>(participant + i);
  g[15] = entity;
  return g;
}

std::string ErrorOf(const msg::StreamStatus& m) {
  try {
    StatusFromMsg(m);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(Protocol, ComponentNamesRoundTrip) {
  for (const char* name : {"player", "detector", "slam", "mapper", "recorder", "ros2_bridge"}) {
    const auto kind = ComponentKindFromName(name);
    ASSERT_TRUE(kind.has_value()) << name;
    EXPECT_STREQ(ToString(*kind), name);
  }
  EXPECT_FALSE(ComponentKindFromName("Slam").has_value());
  EXPECT_FALSE(ComponentKindFromName("").has_value());
}

TEST(Protocol, FailureRules) {
  EXPECT_TRUE(FailureStopsPipeline(ComponentKind::kPlayer));
  EXPECT_TRUE(FailureStopsPipeline(ComponentKind::kRos2Bridge));
  EXPECT_TRUE(FailureStopsPipeline(ComponentKind::kSlam));
  EXPECT_FALSE(FailureStopsPipeline(ComponentKind::kDetector));
  EXPECT_FALSE(FailureStopsPipeline(ComponentKind::kRecorder));
  EXPECT_FALSE(FailureFailsRun(ComponentKind::kDetector));
  EXPECT_TRUE(FailureFailsRun(ComponentKind::kMapper));
  EXPECT_TRUE(WritesOutputs(ComponentKind::kRecorder));
  EXPECT_TRUE(WritesOutputs(ComponentKind::kMapper));
  EXPECT_FALSE(WritesOutputs(ComponentKind::kSlam));
}

TEST(Protocol, GuidHex) {
  const WriterGuid g = Guid(0xa0, 0x03);
  const std::string hex = ToHex(g);
  EXPECT_EQ(hex.size(), 32u);
  EXPECT_EQ(hex.substr(0, 4), "a0a1");
  EXPECT_EQ(WriterGuidFromHex(hex), g);
  EXPECT_EQ(WriterGuidFromHex(std::string(32, 'F')), WriterGuid{[] {
              WriterGuid all{};
              all.fill(0xff);
              return all;
            }()});
  EXPECT_FALSE(WriterGuidFromHex(hex.substr(1)).has_value());
  EXPECT_FALSE(WriterGuidFromHex(std::string(31, '0') + "g").has_value());
}

TEST(Protocol, EveryStatusRoundTrips) {
  const std::vector<ComponentStatus> statuses = {
      ComponentStatus::Started(
          ComponentKind::kPlayer,
          {{DataTopic::kFrames, Guid(1, 2)}, {DataTopic::kGroundTruth, Guid(1, 3)}}, 360),
      ComponentStatus::Started(ComponentKind::kRecorder, {}),
      ComponentStatus::Ready(ComponentKind::kSlam),
      ComponentStatus::EndOfStream(ComponentKind::kRos2Bridge, 42, 41),
      ComponentStatus::Done(ComponentKind::kMapper, 17),
      ComponentStatus::Failed(ComponentKind::kPlayer, "rgb/1.png: does not decode"),
      ComponentStatus::MapLoaded(ComponentKind::kSlam, 33, 0x0123456789abcdefULL,
                                 "/tmp/a map.dmap")};
  for (const ComponentStatus& s : statuses) {
    SCOPED_TRACE(ToString(s.event));
    const ComponentStatus back = StatusFromMsg(ToMsg(s));
    EXPECT_EQ(back.event, s.event);
    EXPECT_EQ(back.source, s.source);
    EXPECT_EQ(back.num_frames, s.num_frames);
    EXPECT_EQ(back.seq, s.seq);
    EXPECT_EQ(back.writers, s.writers);
    EXPECT_EQ(back.reason, s.reason);
    EXPECT_EQ(back.map_checksum, s.map_checksum);
    EXPECT_EQ(back.map_path, s.map_path);
  }
}

// What the components wrote before this protocol still reads (kind values, map announcement).
TEST(Protocol, ReadsTheEarlierWireForm) {
  msg::StreamStatus started;
  started.kind(0);
  started.source("slam");
  const ComponentStatus s = StatusFromMsg(started);
  EXPECT_EQ(s.event, StreamEvent::kStarted);
  EXPECT_TRUE(s.writers.empty());

  msg::StreamStatus loaded;
  loaded.kind(3);
  loaded.source("slam");
  loaded.num_frames(12);
  loaded.header().frame_id("map 00000000deadbeef maps/office.dmap");
  const ComponentStatus l = StatusFromMsg(loaded);
  EXPECT_EQ(l.event, StreamEvent::kMapLoaded);
  EXPECT_EQ(l.map_checksum, 0xdeadbeefULL);
  EXPECT_EQ(l.map_path, "maps/office.dmap");
  EXPECT_EQ(ToMsg(l).header().frame_id(), loaded.header().frame_id());

  msg::StreamStatus end;
  end.kind(1);
  end.source("player");
  end.num_frames(300);
  end.header().seq(299);
  const ComponentStatus e = StatusFromMsg(end);
  EXPECT_EQ(e.event, StreamEvent::kEndOfStream);
  EXPECT_EQ(e.seq, 299u);
}

TEST(Protocol, RefusesWhatItDoesNotUnderstandNamingTheField) {
  msg::StreamStatus m = ToMsg(ComponentStatus::Ready(ComponentKind::kSlam));
  m.source("intruder");
  EXPECT_NE(ErrorOf(m).find("StreamStatus.source"), std::string::npos);
  EXPECT_NE(ErrorOf(m).find("intruder"), std::string::npos);
  m.source(std::string(100000, 'x'));
  EXPECT_LT(ErrorOf(m).size(), 400u) << "a huge source is not echoed whole";

  m = ToMsg(ComponentStatus::Ready(ComponentKind::kSlam));
  m.kind(9);
  EXPECT_NE(ErrorOf(m).find("StreamStatus.kind"), std::string::npos);

  for (const std::string& detail :
       {std::string("writer frames=00"), "writers frames=" + std::string(31, '0'),
        "writers nonsense=" + std::string(32, '0'), std::string("writers frames"),
        "writers frames=" + std::string(32, 'z')}) {
    SCOPED_TRACE(detail);
    m = ToMsg(ComponentStatus::Started(ComponentKind::kPlayer, {}));
    m.header().frame_id(detail);
    EXPECT_NE(ErrorOf(m).find("StreamStatus.header.frame_id"), std::string::npos);
  }
  for (const std::string& detail :
       {std::string("map"), std::string("map xyz"), std::string("map 0123456789abcdeg x")}) {
    SCOPED_TRACE(detail);
    m = ToMsg(ComponentStatus::MapLoaded(ComponentKind::kSlam, 1, 2, "p"));
    m.header().frame_id(detail);
    EXPECT_NE(ErrorOf(m).find("MAP_LOADED"), std::string::npos);
  }
}

TEST(Protocol, RunWritersAcceptOnlyAnnouncedWritersPerTopic) {
  RunWriters writers;
  const WriterGuid frames = Guid(1, 2), truth = Guid(1, 3), other = Guid(9, 2);
  EXPECT_FALSE(writers.Owns(DataTopic::kFrames, frames));
  writers.Announce(ComponentStatus::Started(
      ComponentKind::kPlayer, {{DataTopic::kFrames, frames}, {DataTopic::kGroundTruth, truth}}));
  EXPECT_TRUE(writers.Owns(DataTopic::kFrames, frames));
  EXPECT_TRUE(writers.Owns(DataTopic::kGroundTruth, truth));
  EXPECT_FALSE(writers.Owns(DataTopic::kGroundTruth, frames)) << "a writer owns its topic only";
  EXPECT_FALSE(writers.Owns(DataTopic::kFrames, other));
  // Only STARTED announces writers.
  ComponentStatus ready = ComponentStatus::Ready(ComponentKind::kDetector);
  ready.writers[DataTopic::kDetections] = other;
  writers.Announce(ready);
  EXPECT_FALSE(writers.Owns(DataTopic::kDetections, other));
  // A restarted component announces new writers; the old ones stay this run's.
  const WriterGuid detector1 = Guid(3, 2), detector2 = Guid(4, 2);
  writers.Announce(
      ComponentStatus::Started(ComponentKind::kDetector, {{DataTopic::kDetections, detector1}}));
  writers.Announce(
      ComponentStatus::Started(ComponentKind::kDetector, {{DataTopic::kDetections, detector2}}));
  EXPECT_TRUE(writers.Owns(DataTopic::kDetections, detector1));
  EXPECT_TRUE(writers.Owns(DataTopic::kDetections, detector2));
  EXPECT_EQ(writers.NumAnnounced(DataTopic::kDetections), 2u);
}

// A second player started on the run's partition must not feed the run. The first
// frame source to announce itself plays; another one that announces itself meanwhile is a rival:
// its writers are not accepted and its END_OF_STREAM / FAILED are not the run's.
TEST(Protocol, RunWritersRejectASecondFrameSource) {
  RunWriters writers;
  const WriterGuid player_frames = Guid(1, 2), player_truth = Guid(1, 3),
                   player_status = Guid(1, 4);
  const WriterGuid rival_frames = Guid(7, 2), rival_truth = Guid(7, 3), rival_status = Guid(7, 4);
  EXPECT_TRUE(writers.Announce(
      ComponentStatus::Started(ComponentKind::kPlayer, {{DataTopic::kFrames, player_frames},
                                                        {DataTopic::kGroundTruth, player_truth}}),
      player_status));
  EXPECT_EQ(writers.NumRivals(), 0u);
  EXPECT_FALSE(writers.Announce(
      ComponentStatus::Started(ComponentKind::kPlayer, {{DataTopic::kFrames, rival_frames},
                                                        {DataTopic::kGroundTruth, rival_truth}}),
      rival_status));
  EXPECT_EQ(writers.NumRivals(), 1u);
  EXPECT_NE(writers.LastRival().find("player (participant 07"), std::string::npos)
      << writers.LastRival();
  EXPECT_TRUE(writers.Owns(DataTopic::kFrames, player_frames));
  EXPECT_FALSE(writers.Owns(DataTopic::kFrames, rival_frames));
  EXPECT_FALSE(writers.Owns(DataTopic::kGroundTruth, rival_truth));
  // The rival's end of stream and failure are not the run's; the run's player's are.
  EXPECT_FALSE(
      writers.Announce(ComponentStatus::EndOfStream(ComponentKind::kPlayer, 5, 4), rival_status));
  EXPECT_FALSE(
      writers.Announce(ComponentStatus::Failed(ComponentKind::kPlayer, "x"), rival_status));
  // Other components' statuses pass, whoever sends them.
  EXPECT_TRUE(writers.Announce(ComponentStatus::Ready(ComponentKind::kSlam), Guid(3, 4)));
  EXPECT_TRUE(writers.Announce(ComponentStatus::EndOfStream(ComponentKind::kPlayer, 40, 39),
                               player_status));
  // The run's player is done: a player started after it plays (a replay), a rival stays one.
  const WriterGuid next_frames = Guid(9, 2);
  EXPECT_TRUE(writers.Announce(
      ComponentStatus::Started(ComponentKind::kPlayer, {{DataTopic::kFrames, next_frames}}),
      Guid(9, 4)));
  EXPECT_TRUE(writers.Owns(DataTopic::kFrames, next_frames));
  EXPECT_FALSE(writers.Announce(
      ComponentStatus::Started(ComponentKind::kPlayer, {{DataTopic::kFrames, rival_frames}}),
      rival_status));
  // Without the status writer's GUID, the frames writer tells the participant.
  RunWriters plain;
  EXPECT_TRUE(plain.Announce(
      ComponentStatus::Started(ComponentKind::kPlayer, {{DataTopic::kFrames, player_frames}})));
  EXPECT_FALSE(plain.Announce(
      ComponentStatus::Started(ComponentKind::kRos2Bridge, {{DataTopic::kFrames, rival_frames}})));
  EXPECT_FALSE(plain.Owns(DataTopic::kFrames, rival_frames));
}

TEST(Protocol, GateHoldsEarlySamplesUntilTheAnnouncementInWriterOrder) {
  RunWriters writers;
  WriterGate<int> gate(&writers, DataTopic::kDetections, 8, milliseconds(1000));
  const WriterGuid restarted = Guid(4, 2), stranger = Guid(9, 9);
  const Clock::time_point t0 = Clock::now();
  std::vector<int> ready;
  // A restarted detector's first samples arrive before its STARTED; a stranger's too.
  gate.Offer(1, restarted, t0, &ready);
  gate.Offer(100, stranger, t0, &ready);
  gate.Offer(2, restarted, t0 + milliseconds(10), &ready);
  EXPECT_TRUE(ready.empty());
  EXPECT_EQ(gate.held(), 3u);
  writers.Announce(
      ComponentStatus::Started(ComponentKind::kDetector, {{DataTopic::kDetections, restarted}}));
  // The next sample of that writer comes after its held ones.
  gate.Offer(3, restarted, t0 + milliseconds(20), &ready);
  EXPECT_EQ(ready, (std::vector<int>{1, 2, 3}));
  EXPECT_EQ(gate.held(), 1u);
  // The stranger never announces: its sample expires after max_hold and counts as ignored.
  ready.clear();
  gate.Release(t0 + milliseconds(1500), &ready);
  EXPECT_TRUE(ready.empty());
  EXPECT_EQ(gate.held(), 0u);
  EXPECT_EQ(gate.ignored(), 1u);
}

TEST(Protocol, GateReleaseAfterAnnouncementAndBounds) {
  RunWriters writers;
  WriterGate<int> gate(&writers, DataTopic::kFrames, 3, milliseconds(1000));
  const WriterGuid player = Guid(1, 2), stranger = Guid(9, 9);
  const Clock::time_point t0 = Clock::now();
  std::vector<int> ready;
  for (int i = 0; i < 5; ++i) gate.Offer(i, player, t0, &ready);
  EXPECT_EQ(gate.held(), 3u) << "holds at most max_held";
  EXPECT_EQ(gate.ignored(), 2u);
  writers.Announce(
      ComponentStatus::Started(ComponentKind::kPlayer, {{DataTopic::kFrames, player}}));
  gate.Release(t0 + milliseconds(5), &ready);
  EXPECT_EQ(ready, (std::vector<int>{0, 1, 2}));
  // Announced writers pass at once; an unannounced one's samples are held and, at the end, counted.
  ready.clear();
  gate.Offer(7, player, t0 + milliseconds(6), &ready);
  gate.Offer(8, stranger, t0 + milliseconds(6), &ready);
  EXPECT_EQ(ready, (std::vector<int>{7}));
  gate.Close();
  EXPECT_EQ(gate.ignored(), 3u);
}

TEST(Protocol, WriterGoneWatchNeedsSeenThenUnmatchedLongerThanItsTime) {
  using std::chrono::seconds;
  const WriterGoneWatch::Clock::time_point t0{};
  WriterGoneWatch never_matched(seconds(5));
  EXPECT_FALSE(never_matched.Update(false, t0));
  EXPECT_FALSE(never_matched.Update(false, t0 + seconds(60)));  // never there: not gone

  WriterGoneWatch watch(seconds(5));
  EXPECT_FALSE(watch.Update(true, t0));
  EXPECT_FALSE(watch.Update(false, t0 + seconds(1)));  // unmatched since 1 s
  EXPECT_FALSE(watch.Update(false, t0 + seconds(6)));  // 5 s: not longer than 5
  EXPECT_FALSE(watch.Update(true, t0 + seconds(7)));   // back: the clock restarts
  EXPECT_FALSE(watch.Update(false, t0 + seconds(8)));
  EXPECT_FALSE(watch.Update(false, t0 + seconds(12)));
  EXPECT_TRUE(watch.Update(false, t0 + seconds(14)));

  // A peer known to have been there (READY) that left before the first look: gone too.
  WriterGoneWatch left_before(seconds(5));
  left_before.Seen();
  EXPECT_FALSE(left_before.Update(false, t0));
  EXPECT_TRUE(left_before.Update(false, t0 + seconds(6)));
}

TEST(Protocol, IgnoredSamplesNote) {
  const std::string note = IgnoredSamplesNote("7 keyframes");
  EXPECT_NE(note.find("ignored 7 keyframes"), std::string::npos);
  EXPECT_NE(note.find("outside this run"), std::string::npos);
  EXPECT_NE(note.find("--security"), std::string::npos);
}

// The status writer as StartedAnnouncer sees it: what was written, how many readers matched.
struct FakeStatusWriter {
  std::vector<msg::StreamStatus> written;
  int readers = 0;
  bool Write(const msg::StreamStatus& m) {
    written.push_back(m);
    return true;
  }
  int matched() const { return readers; }
};

// STARTED is written at once and again each time more readers are matched than before (a peer
// joined late and may have missed the history); the same count, or fewer, writes nothing.
TEST(StartedAnnouncer, RepeatsTheAnnouncementWhenAPeerJoins) {
  FakeStatusWriter w;
  WriterGuid keyframes{};
  keyframes[15] = 7;
  StartedAnnouncer started(
      w, ComponentStatus::Started(ComponentKind::kSlam, {{DataTopic::kKeyframe, keyframes}}));
  ASSERT_EQ(w.written.size(), 1u);
  started.Poll(w);  // nobody there yet
  EXPECT_EQ(w.written.size(), 1u);
  w.readers = 3;  // the run's peers
  started.Poll(w);
  EXPECT_EQ(w.written.size(), 2u);
  started.Poll(w);
  EXPECT_EQ(w.written.size(), 2u);
  w.readers = 2;  // one left
  started.Poll(w);
  EXPECT_EQ(w.written.size(), 2u);
  w.readers = 3;  // a late joiner (a mapper started mid-run)
  started.Poll(w);
  ASSERT_EQ(w.written.size(), 3u);
  EXPECT_EQ(started.repeats(), 2);
  // Every copy is the same announcement, and RunWriters takes it any number of times.
  RunWriters writers;
  for (const msg::StreamStatus& m : w.written) {
    const ComponentStatus s = StatusFromMsg(m);
    EXPECT_EQ(s.event, StreamEvent::kStarted);
    EXPECT_TRUE(writers.Announce(s));
  }
  EXPECT_TRUE(writers.Owns(DataTopic::kKeyframe, keyframes));
  EXPECT_EQ(writers.NumAnnounced(DataTopic::kKeyframe), 1u);
}

}  // namespace
}  // namespace dygslam
