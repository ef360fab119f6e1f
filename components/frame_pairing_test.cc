#include "components/frame_pairing.h"

#include <gtest/gtest.h>

#include <string>

#include "core/base/error.h"

namespace dygslam {
namespace {

using namespace std::chrono_literals;
using Clock = FramePairer::Clock;

RgbdFrameData Frame(int64_t i) {
  RgbdFrameData f;
  f.stamp = Timestamp::FromNanoseconds(1000 + i * 33);
  f.seq = static_cast<uint64_t>(i);
  return f;
}

std::vector<Detection> OneBox() {
  Detection d;
  d.box = cv::Rect2f(1, 2, 3, 4);
  d.label = "person";
  return {d};
}

// Every 3rd frame is the detector's: the frames the cadence skips after a frame that got no boxes
// (not even carried ones) have nothing to carry and count too. Before, only the detector's frames
// counted: a third of the frames that ran geometry-only.
TEST(BoxCoverage, FramesSkippedAfterAFrameWithoutBoxesCountToo) {
  const auto frame = [](bool skipped, bool missing, bool carried) {
    PairedFrame p;
    p.detector_skipped = skipped;
    p.detections_missing = missing;
    p.detections_carried_forward = carried;
    return p;
  };
  BoxCoverage coverage;
  for (int cycle = 0; cycle < 2; ++cycle) {  // boxes, then skipped frames carrying them
    coverage.Add(frame(false, false, false));
    coverage.Add(frame(true, false, false));
    coverage.Add(frame(true, false, false));
  }
  EXPECT_EQ(coverage.frames_without_boxes(), 0u);
  coverage.Add(frame(false, true, true));  // the detector late: boxes carried forward
  coverage.Add(frame(true, false, false));
  coverage.Add(frame(true, false, false));
  EXPECT_EQ(coverage.frames_without_boxes(), 0u);
  for (int cycle = 0; cycle < 4; ++cycle) {  // the detector lost: nothing to carry
    coverage.Add(frame(false, true, false));
    coverage.Add(frame(true, false, false));
    coverage.Add(frame(true, false, false));
  }
  EXPECT_EQ(coverage.frames_without_boxes(), 12u);
  coverage.Add(frame(false, false, false));  // detections again
  coverage.Add(frame(true, false, false));
  EXPECT_EQ(coverage.frames_without_boxes(), 12u);
}

TEST(FramePairing, PairsByStampInArrivalOrder) {
  PairingOptions o;
  FramePairer p(o);
  const auto t0 = Clock::now();
  p.AddFrame(Frame(0), t0);
  p.AddFrame(Frame(1), t0);
  p.AddDetections(Frame(1).stamp, OneBox());
  EXPECT_FALSE(p.Next(t0).has_value());  // frame 0 waits for its own detections
  p.AddDetections(Frame(0).stamp, {});
  auto a = p.Next(t0);
  ASSERT_TRUE(a);
  EXPECT_EQ(a->frame.seq, 0u);
  ASSERT_TRUE(a->detections);
  EXPECT_TRUE(a->detections->empty());
  auto b = p.Next(t0);
  ASSERT_TRUE(b);
  EXPECT_EQ(b->frame.seq, 1u);
  ASSERT_TRUE(b->detections);
  EXPECT_EQ(b->detections->size(), 1u);
  EXPECT_EQ(p.stats().with_detections, 2u);
}

TEST(FramePairing, NormalModeWaitsBoundedThenCountsMiss) {
  PairingOptions o;
  o.max_wait = 100ms;
  FramePairer p(o);
  const auto t0 = Clock::now();
  p.AddFrame(Frame(0), t0);
  EXPECT_FALSE(p.Next(t0 + 50ms));
  ASSERT_TRUE(p.NextDeadline());
  EXPECT_EQ(*p.NextDeadline(), t0 + 100ms);
  auto f = p.Next(t0 + 100ms);
  ASSERT_TRUE(f);
  EXPECT_FALSE(f->detections);
  EXPECT_TRUE(f->detections_missing);
  EXPECT_EQ(p.stats().missing_detections, 1u);
  // Late detections of a released frame are dropped.
  p.AddDetections(Frame(0).stamp, OneBox());
  EXPECT_EQ(p.stats().dropped_detections, 1u);
}

TEST(FramePairing, DeterministicWaitsUntilDetectorIsGone) {
  PairingOptions o;
  o.deterministic = true;
  o.max_wait = 1ms;
  FramePairer p(o);
  const auto t0 = Clock::now();
  p.AddFrame(Frame(0), t0);
  EXPECT_FALSE(p.Next(t0 + 1h));
  EXPECT_FALSE(p.NextDeadline());
  p.SetDetectorAlive(false);  // detector writer disappeared (killed)
  auto f = p.Next(t0 + 1h);
  ASSERT_TRUE(f);
  EXPECT_TRUE(f->detections_missing);
  EXPECT_TRUE(p.detector_lost());
  EXPECT_EQ(p.stats().lost_episodes, 1u);
}

TEST(FramePairing, ConsecutiveMissesDeclareDetectorLostThenRecover) {
  PairingOptions o;
  o.max_wait = 10ms;
  o.lost_after_misses = 3;
  FramePairer p(o);
  auto t = Clock::now();
  for (int i = 0; i < 3; ++i) {
    p.AddFrame(Frame(i), t);
    ASSERT_TRUE(p.Next(t + 10ms));
  }
  EXPECT_TRUE(p.detector_lost());
  // Lost: frames no longer wait at all (geometry-only).
  p.AddFrame(Frame(3), t);
  auto f = p.Next(t);
  ASSERT_TRUE(f);
  EXPECT_TRUE(f->detections_missing);
  // Detections arrive again: waiting resumes and pairing works.
  p.AddDetections(Frame(4).stamp, OneBox());
  EXPECT_FALSE(p.detector_lost());
  p.AddFrame(Frame(4), t);
  auto g = p.Next(t);
  ASSERT_TRUE(g);
  ASSERT_TRUE(g->detections);
  EXPECT_EQ(p.stats().lost_episodes, 1u);
  EXPECT_EQ(p.stats().missing_detections, 4u);
}

TEST(FramePairing, NoDetectionsNeededNoWait) {
  PairingOptions o;
  o.needs_detections = false;
  FramePairer p(o);
  const auto t0 = Clock::now();
  p.AddFrame(Frame(0), t0);
  auto f = p.Next(t0);
  ASSERT_TRUE(f);
  EXPECT_FALSE(f->detections_missing);
  EXPECT_FALSE(f->detections);
}

// A frame whose detections do not come in time gets the newest earlier boxes.
TEST(FramePairing, MissingDetectionsGetTheLastBoxesCarriedForward) {
  PairingOptions o;
  o.max_wait = 10ms;
  o.carry_forward_max_frames = 2;
  o.lost_after_misses = 100;
  FramePairer p(o);
  const auto t0 = Clock::now();
  p.AddFrame(Frame(0), t0);
  p.AddDetections(Frame(0).stamp, OneBox());
  ASSERT_TRUE(p.Next(t0)->detections);
  for (int i = 1; i <= 3; ++i) p.AddFrame(Frame(i), t0);
  auto a = p.Next(t0 + 10ms);
  ASSERT_TRUE(a && a->detections);
  EXPECT_TRUE(a->detections_missing);
  EXPECT_TRUE(a->detections_carried_forward);
  EXPECT_EQ(a->carried_from, Frame(0).stamp);
  EXPECT_EQ(a->detections->front().box, OneBox().front().box);
  auto b = p.Next(t0 + 10ms);
  ASSERT_TRUE(b && b->detections_carried_forward);
  auto c = p.Next(t0 + 10ms);  // third in a row: over the limit, geometry-only
  ASSERT_TRUE(c);
  EXPECT_FALSE(c->detections);
  EXPECT_FALSE(c->detections_carried_forward);
  EXPECT_TRUE(c->detections_missing);
  EXPECT_EQ(p.stats().carried_forward, 2u);
  EXPECT_EQ(p.stats().missing_detections, 3u);
}

TEST(FramePairing, LateDetectionsAreCarriedForwardNotDropped) {
  PairingOptions o;
  o.max_wait = 10ms;
  FramePairer p(o);
  const auto t0 = Clock::now();
  p.AddFrame(Frame(0), t0);
  auto a = p.Next(t0 + 10ms);  // nothing yet, nothing to carry: geometry-only
  ASSERT_TRUE(a);
  EXPECT_FALSE(a->detections);
  std::vector<Detection> late = OneBox();
  late.front().box = cv::Rect2f(100, 100, 50, 120);
  p.AddDetections(Frame(0).stamp, late);  // frame 0 is gone: the boxes go to the next frames
  EXPECT_EQ(p.stats().dropped_detections, 1u);
  EXPECT_EQ(p.stats().late_used, 1u);
  p.AddFrame(Frame(1), t0 + 33ms);
  auto b = p.Next(t0 + 43ms);
  ASSERT_TRUE(b && b->detections);
  EXPECT_TRUE(b->detections_carried_forward);
  EXPECT_EQ(b->detections->front().box, late.front().box);
  // Boxes older than carry_forward_max_age are not carried.
  PairingOptions strict = o;
  strict.carry_forward_max_age = std::chrono::milliseconds(0);
  FramePairer q(strict);
  q.AddFrame(Frame(0), t0);
  q.AddDetections(Frame(0).stamp, OneBox());
  ASSERT_TRUE(q.Next(t0));
  q.AddFrame(Frame(1), t0);
  auto c = q.Next(t0 + 10ms);
  ASSERT_TRUE(c);
  EXPECT_FALSE(c->detections);
}

TEST(FramePairing, DetectorFinishingBeforeItsStatusIsNotALoss) {
  // The detector paired every frame, then its writer went away before its "done" status was
  // seen: no frame lacked its boxes, so nothing is reported lost.
  PairingOptions o;
  o.deterministic = true;
  FramePairer p(o);
  const auto t0 = Clock::now();
  p.AddFrame(Frame(0), t0);
  p.AddDetections(Frame(0).stamp, OneBox());
  p.SetDetectorAlive(false);
  auto f = p.Next(t0);
  ASSERT_TRUE(f);
  EXPECT_FALSE(f->detections_missing);
  EXPECT_EQ(p.stats().lost_episodes, 0u);
  // A later frame without boxes is the loss: counted once, carried-forward boxes used.
  p.AddFrame(Frame(1), t0);
  p.AddFrame(Frame(2), t0);
  auto g = p.Next(t0);
  ASSERT_TRUE(g);
  EXPECT_TRUE(g->detections_missing);
  EXPECT_TRUE(g->detections_carried_forward);
  ASSERT_TRUE(p.Next(t0));
  EXPECT_EQ(p.stats().lost_episodes, 1u);
}

// Detector cadence (every 3rd frame detected): the frames in between are released at once, even
// in deterministic mode, marked detector_skipped and not counted as missing; the detector frames
// still wait for their own detections; an invalid cadence is rejected naming the key.
TEST(FramePairing, CadenceReleasesSkippedFramesWithoutWaiting) {
  PairingOptions o;
  o.deterministic = true;
  o.detection_every_n_frames = 3;
  FramePairer p(o);
  const auto t0 = Clock::now();
  for (int64_t i = 0; i < 7; ++i) p.AddFrame(Frame(i), t0);
  EXPECT_FALSE(p.Next(t0 + 1h));  // frame 0 is a detector frame: it waits
  p.AddDetections(Frame(0).stamp, OneBox());
  auto f0 = p.Next(t0);
  ASSERT_TRUE(f0);
  EXPECT_FALSE(f0->detector_skipped);
  ASSERT_TRUE(f0->detections);
  for (uint64_t seq : {1u, 2u}) {
    ASSERT_TRUE(p.NextDeadline());
    EXPECT_EQ(*p.NextDeadline(), t0);  // ready now
    auto f = p.Next(t0);
    ASSERT_TRUE(f);
    EXPECT_EQ(f->frame.seq, seq);
    EXPECT_TRUE(f->detector_skipped);
    EXPECT_FALSE(f->detections);
    EXPECT_FALSE(f->detections_missing);
    EXPECT_FALSE(f->detections_carried_forward);
  }
  EXPECT_FALSE(p.Next(t0 + 1h));  // frame 3 waits for its detections
  EXPECT_FALSE(p.NextDeadline());
  p.AddDetections(Frame(3).stamp, {});
  auto f3 = p.Next(t0);
  ASSERT_TRUE(f3);
  EXPECT_EQ(f3->frame.seq, 3u);
  EXPECT_FALSE(f3->detector_skipped);
  EXPECT_EQ(p.stats().skipped_by_cadence, 2u);
  EXPECT_EQ(p.stats().with_detections, 2u);
  EXPECT_EQ(p.stats().missing_detections, 0u);
  EXPECT_FALSE(p.detector_lost());

  PairingOptions bad;
  bad.detection_every_n_frames = 0;
  try {
    FramePairer rejected(bad);
    ADD_FAILURE() << "every_n_frames 0 accepted";
  } catch (const InvalidOptions& e) {
    EXPECT_NE(std::string(e.what()).find("Detector.every_n_frames"), std::string::npos) << e.what();
  }
}

// Normal mode with the cadence: a skipped frame never counts toward the detector being lost.
TEST(FramePairing, CadenceSkippedFramesAreNotMisses) {
  PairingOptions o;
  o.max_wait = 10ms;
  o.lost_after_misses = 2;
  o.detection_every_n_frames = 2;
  FramePairer p(o);
  const auto t0 = Clock::now();
  for (int64_t i = 0; i < 8; ++i) {
    p.AddFrame(Frame(i), t0);
    if (i % 2 == 0) p.AddDetections(Frame(i).stamp, OneBox());
  }
  for (int64_t i = 0; i < 8; ++i) {
    auto f = p.Next(t0);
    ASSERT_TRUE(f) << i;
    EXPECT_EQ(f->detector_skipped, i % 2 == 1) << i;
    EXPECT_EQ(f->detections.has_value(), i % 2 == 0) << i;
  }
  EXPECT_EQ(p.stats().skipped_by_cadence, 4u);
  EXPECT_EQ(p.stats().missing_detections, 0u);
  EXPECT_EQ(p.stats().lost_episodes, 0u);
}

// A camera does not wait: frames that arrive while more than max_pending_frames wait push the
// oldest out (counted), so the frame tracked next is at most that many frames old. Before, every
// frame waited: a slam slower than the camera fell further behind (latency growing to seconds,
// nothing dropped).
TEST(FramePairing, MoreFramesThanTheBoundPushTheOldestOut) {
  PairingOptions o;
  o.max_pending_frames = 3;
  o.needs_detections = false;  // each frame is ready as it arrives
  const auto t0 = Clock::now();
  FramePairer p(o);
  for (int i = 0; i < 5; ++i) p.AddFrame(Frame(i), t0);
  EXPECT_EQ(p.pending_frames(), 3u);
  EXPECT_EQ(p.stats().dropped_frames, 2u);
  auto f = p.Next(t0);
  ASSERT_TRUE(f);
  EXPECT_EQ(f->frame.seq, 2u);  // the oldest of the newest three
  // A frame at the bound is kept: a player with a window of 3 is never cut.
  FramePairer windowed(o);
  for (int i = 0; i < 3; ++i) windowed.AddFrame(Frame(i), t0);
  EXPECT_EQ(windowed.pending_frames(), 3u);
  EXPECT_EQ(windowed.stats().dropped_frames, 0u);
  o.max_pending_frames = 0;  // no bound
  FramePairer unbounded(o);
  for (int i = 0; i < 100; ++i) unbounded.AddFrame(Frame(i), t0);
  EXPECT_EQ(unbounded.pending_frames(), 100u);
}

// The oldest frame waiting for its detections holds the frames behind it: that wait has its own
// bound (max_wait, then the detector counts as lost). A detector paused for seconds must make
// the frames run without boxes (counted, the run incomplete), not vanish as dropped. The excess
// goes once the oldest is ready; a dropped frame's detections that come later are late (carried
// forward), never paired with a newer frame.
TEST(FramePairing, FramesBehindAFrameWaitingForItsDetectionsAreKept) {
  PairingOptions o;
  o.max_pending_frames = 3;
  o.max_wait = 100ms;
  const auto t0 = Clock::now();
  FramePairer p(o);
  p.AddDetections(Frame(0).stamp, OneBox());
  for (int i = 0; i < 6; ++i) p.AddFrame(Frame(i), t0);
  // Frame 0 had its boxes (ready): over the bound, it went. Frame 1 waits: all stay.
  EXPECT_EQ(p.stats().dropped_frames, 1u);
  EXPECT_EQ(p.pending_frames(), 5u);
  EXPECT_FALSE(p.Next(t0 + 50ms));
  p.AddDetections(Frame(1).stamp, OneBox());  // frame 1 ready: over the bound, it goes
  EXPECT_FALSE(p.Next(t0 + 50ms));            // frame 2 waits for its boxes
  EXPECT_EQ(p.stats().dropped_frames, 2u);
  EXPECT_EQ(p.pending_frames(), 4u);
  auto f = p.Next(t0 + 100ms);  // its wait is over: it goes on without its own boxes
  ASSERT_TRUE(f);
  EXPECT_EQ(f->frame.seq, 2u);
  EXPECT_TRUE(f->detections_missing);
  EXPECT_EQ(p.stats().missing_detections, 1u);
  p.AddDetections(Frame(1).stamp, {});  // the dropped frame's boxes once more: late
  EXPECT_EQ(p.stats().dropped_detections, 1u);
}

}  // namespace
}  // namespace dygslam
