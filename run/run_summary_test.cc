#include "run/run_summary.h"

#include <gtest/gtest.h>

namespace dygslam {
namespace {

RunSummary Complete() {
  RunSummary s;
  s.mode = "direct (no DDS)";
  s.filter = "full";
  s.first = 0;
  s.last = 360;
  s.requested = 360;
  s.processed = 360;
  s.states = {{"ok", 343}, {"fallback", 15}, {"relocalized", 2}};
  s.in_trajectory = 360;
  s.seconds = 9.0;
  s.ate = AteFigures{0.0142, 0.0126, 0.0115, 0.0497, 360};
  s.online_ate = AteFigures{0.0143, 0.0123, 0.0103, 0.0455, 360};
  return s;
}

bool Has(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

TEST(RunSummary, CompleteRunListsItsFramesAndBothAccuracies) {
  const RunSummary s = Complete();
  EXPECT_EQ(s.WithPose(), 360u);
  EXPECT_EQ(s.Reason(), Shortfall::kNone);
  const std::string json = RunSummaryJson(s);
  EXPECT_TRUE(Has(json,
                  "\"requested\": 360, \"without_depth_partner\": 0, \"processed\": 360, "
                  "\"foreign\": 0, \"with_pose\": 360, \"in_trajectory\": 360, \"missing\": 0"))
      << json;
  EXPECT_TRUE(Has(json, "\"states\": {\"fallback\": 15, \"ok\": 343, \"relocalized\": 2}")) << json;
  EXPECT_TRUE(Has(json, "\"complete\": true, \"shortfall\": \"none\"")) << json;
  EXPECT_TRUE(Has(json, "\"fps\": 40")) << json;
  EXPECT_TRUE(Has(json, "\"ate\": {\"rmse\": 0.0142,")) << json;
  EXPECT_TRUE(Has(json, "\"online_ate\": {\"rmse\": 0.0143,")) << json;
  EXPECT_TRUE(Has(json, "\"realtime\": null")) << json;
}

TEST(RunSummary, EveryShortfallHasItsReason) {
  RunSummary s = Complete();
  s.processed = 150;
  EXPECT_EQ(s.Missing(), 210u);
  EXPECT_EQ(s.Reason(), Shortfall::kCutShort);
  EXPECT_TRUE(Has(RunSummaryJson(s), "\"missing\": 210")) << RunSummaryJson(s);
  EXPECT_TRUE(Has(RunSummaryJson(s), "\"complete\": false, \"shortfall\": \"the stream was cut"));
  s.realtime = RealtimeReport{1.0, 360, 352, 0, 19.4, 76.3};
  // The camera's pace explains 8 dropped frames, not 210 missing ones.
  EXPECT_EQ(s.Reason(), Shortfall::kCutShort);
  s.processed = 352;
  EXPECT_EQ(s.Reason(), Shortfall::kDroppedByRate);
  // Dropped during a stall (no result for 25 s: a component paused): not the camera's pace.
  s.realtime->longest_gap_s = 25;
  EXPECT_EQ(s.Reason(), Shortfall::kCutShort);
  EXPECT_TRUE(Has(s.realtime->Summary(), "stalled: no result for 25.0 s")) << s.realtime->Summary();
  s.realtime->longest_gap_s = 0.2;
  EXPECT_TRUE(Has(RunSummaryJson(s), "\"dropped\": 8, \"late\": 0")) << RunSummaryJson(s);
  s.processed = 150;
  s.interrupted = true;  // the user's stop explains the missing frames
  EXPECT_EQ(s.Reason(), Shortfall::kStoppedByUser);
  s.component_failed = true;  // a failed component comes first
  EXPECT_EQ(s.Reason(), Shortfall::kComponentFailed);
  // A failed run is never complete, even with every frame processed (a looped run, a component
  // that failed at the end).
  RunSummary failed = Complete();
  failed.component_failed = true;
  EXPECT_FALSE(failed.Complete());
  EXPECT_TRUE(Has(RunSummaryJson(failed), "\"complete\": false")) << RunSummaryJson(failed);
  // Frames of another frame source (a second player on the partition): never complete, even
  // with as many frames as requested.
  RunSummary mixed = Complete();
  mixed.foreign_frames = 100;
  EXPECT_EQ(mixed.Reason(), Shortfall::kForeignFrames);
  EXPECT_FALSE(mixed.Complete());
  EXPECT_TRUE(Has(RunSummaryJson(mixed), "\"foreign\": 100,")) << RunSummaryJson(mixed);
  EXPECT_TRUE(Has(RunSummaryJson(mixed), "\"complete\": false")) << RunSummaryJson(mixed);
  // Every frame processed, but the mapper was stopped on its own: its map ends early.
  RunSummary stopped = Complete();
  stopped.components_cut_short = {"mapper (signal 15)"};
  EXPECT_EQ(stopped.Reason(), Shortfall::kComponentCutShort);
  EXPECT_FALSE(stopped.Complete());
  EXPECT_TRUE(Has(RunSummaryJson(stopped), "\"components_cut_short\": [\"mapper (signal 15)\"]"))
      << RunSummaryJson(stopped);
  // A looped replay that ended before its time: cut short, though more frames than the sequence
  // holds were processed.
  RunSummary looped = Complete();
  looped.processed = 3 * looped.requested;
  looped.loop_ended_early = true;
  EXPECT_EQ(looped.Reason(), Shortfall::kCutShort);
  EXPECT_FALSE(looped.Complete());
}

TEST(RunSummary, MissingAccuracyIsNullWithItsReason) {
  RunSummary s = Complete();
  s.ate.reset();
  s.online_ate.reset();
  s.ate_note = "no stamp in common";
  const std::string json = RunSummaryJson(s);
  EXPECT_TRUE(Has(json,
                  "\"ate\": null,\n \"online_ate\": null,\n \"ate_note\": \"no stamp in "
                  "common\""))
      << json;
}

}  // namespace
}  // namespace dygslam
