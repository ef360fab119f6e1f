// The run controller on the first frames of bonn_crowd_part: the direct loop end to end (filter
// none, no map: a few seconds), and the pipeline modes' judgement of what the components wrote,
// with a stand-in PipelineRunner that writes the files the recorder would.
#include "run/run_controller.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/io/file_util.h"
#include "core/io/trajectory_io.h"
#include "run/realtime_report.h"
#include "run/run_settings.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

constexpr size_t kFrames = 12;

RunControllerOptions Options(const std::string& dataset, const std::string& out) {
  RunSettingsRequest request;
  request.settings_path = std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/bonn.yaml";
  request.read.print_warnings = false;
  request.filter = "none";
  request.deterministic = true;
  const RunConfiguration c = LoadRunConfiguration(request);
  RunControllerOptions o;
  o.dataset_dir = dataset;
  o.settings_path = request.settings_path;
  o.filter = "none";
  o.system = c.system;
  o.octomap = c.octomap;
  o.first = 0;
  o.last = kFrames;
  o.out = out;
  o.map = false;
  o.progress = false;
  return o;
}

// What the recorder writes for frames with these stamps: frames.csv and a trajectory with a pose
// for each.
void WriteRecorderFiles(const fs::path& out, const std::vector<Timestamp>& stamps) {
  std::string csv = FramesCsvHeader();
  std::set<Timestamp> tracked;  // the trajectory has one pose per stamp, in order
  for (const Timestamp& t : stamps) {
    FrameRow row;
    row.stamp = t;
    row.state = TrackingState::kOk;
    csv += FramesCsvRow(row);
    tracked.insert(t);
  }
  std::vector<StampedPose> poses;
  for (const Timestamp& t : tracked) poses.push_back({t, Rigid3d()});
  WriteFileAtomically((out / "frames.csv").string(), csv);
  WriteTumTrajectory((out / "trajectory.txt").string(), poses);
}

std::vector<Timestamp> DatasetStamps(const RgbdDataset& dataset, size_t n) {
  std::vector<Timestamp> stamps;
  for (size_t k = 0; k < n; ++k) stamps.push_back(dataset.frames()[k].rgb_stamp);
  return stamps;
}

TEST(RunController, DirectRunWritesItsOutputsAndACompleteSummary) {
  DYGSLAM_REQUIRE_DATASET(dir, "bonn_crowd_part");
  const std::string out = testing::MakeTempDir("run_controller_direct");
  const RgbdDataset dataset = RgbdDataset::Open(dir);
  RunController controller(Options(dir, out), dataset,
                           ReadTumTrajectory(dataset.groundtruth_path()));
  EXPECT_EQ(controller.requested(), kFrames);
  EXPECT_EQ(controller.Run(), 0);
  const RunSummary& s = controller.summary();
  EXPECT_EQ(s.mode, "direct (no DDS)");
  EXPECT_EQ(s.processed, kFrames);
  EXPECT_EQ(s.in_trajectory, kFrames);
  EXPECT_TRUE(s.Complete());
  ASSERT_TRUE(s.ate.has_value());
  EXPECT_EQ(s.ate->pairs, kFrames);
  EXPECT_EQ(ReadTumTrajectory(out + "/trajectory.txt").size(), kFrames);
  EXPECT_EQ(ReadTumTrajectory(out + "/trajectory_online.txt").size(), kFrames);
  EXPECT_NE(testing::ReadAll(out + "/eval.json").find("\"complete\": true"), std::string::npos)
      << testing::ReadAll(out + "/eval.json");
  EXPECT_FALSE(fs::exists(out + "/map.bt")) << "map off";
}

TEST(RunController, PipelineRunJudgesTheFilesTheComponentsWrote) {
  DYGSLAM_REQUIRE_DATASET(dir, "bonn_crowd_part");
  const RgbdDataset dataset = RgbdDataset::Open(dir);
  // Every frame: complete.
  {
    const std::string out = testing::MakeTempDir("run_controller_pipeline");
    RunControllerOptions o = Options(dir, out);
    o.mode = RunMode::kPipeline;
    RunController controller(o, dataset, {}, [&](const RunControllerOptions& options) {
      WriteRecorderFiles(options.out, DatasetStamps(dataset, kFrames));
      return PipelineRunResult{};
    });
    EXPECT_EQ(controller.Run(), 0);
    EXPECT_EQ(controller.summary().processed, kFrames);
    EXPECT_TRUE(controller.summary().Complete());
  }
  // Frames of another source among them: not this run's, the run is incomplete (exit 3).
  {
    const std::string out = testing::MakeTempDir("run_controller_foreign");
    RunControllerOptions o = Options(dir, out);
    o.mode = RunMode::kPipelineProcesses;
    RunController controller(o, dataset, {}, [&](const RunControllerOptions& options) {
      std::vector<Timestamp> stamps = DatasetStamps(dataset, kFrames - 2);
      stamps.push_back(Timestamp::FromSeconds(4242.0));
      stamps.push_back(stamps.front());  // a frame that came twice
      WriteRecorderFiles(options.out, stamps);
      return PipelineRunResult{};
    });
    EXPECT_EQ(controller.Run(), kExitIncompleteRun);
    EXPECT_EQ(controller.summary().foreign_frames, 2u);
    EXPECT_EQ(controller.summary().processed, kFrames - 2);
    EXPECT_EQ(controller.summary().Reason(), Shortfall::kForeignFrames);
  }
  // A failed component fails the run (exit 1) and eval.json says so.
  {
    const std::string out = testing::MakeTempDir("run_controller_failed");
    RunControllerOptions o = Options(dir, out);
    o.mode = RunMode::kPipeline;
    RunController controller(o, dataset, {}, [&](const RunControllerOptions& options) {
      WriteRecorderFiles(options.out, DatasetStamps(dataset, 5));
      PipelineRunResult r;
      r.exit_code = 1;
      return r;
    });
    EXPECT_EQ(controller.Run(), 1);
    EXPECT_FALSE(controller.summary().error.empty());
    EXPECT_NE(testing::ReadAll(out + "/eval.json").find("\"exit_code\": 1"), std::string::npos)
        << testing::ReadAll(out + "/eval.json");
  }
  // --rate: the player timed 298 of 300 poses (its reader behind after the whole run was stopped
  // and continued), frames.csv has all 300: the pipeline took every frame, none is dropped, in
  // the summary and in realtime.txt. Before, "1 dropped" beside "300 of 300 processed".
  {
    const std::string out = testing::MakeTempDir("run_controller_untimed");
    RunControllerOptions o = Options(dir, out);
    o.mode = RunMode::kPipeline;
    o.rate = 1;
    RunController controller(o, dataset, {}, [&](const RunControllerOptions& options) {
      WriteRecorderFiles(options.out, DatasetStamps(dataset, kFrames));
      RealtimeReport report;
      report.rate = 1;
      report.frames = kFrames;
      report.results = kFrames - 2;
      WriteRealtimeReport((options.out / kRealtimeReportFile).string(), report);
      return PipelineRunResult{};
    });
    EXPECT_EQ(controller.Run(), 0);
    ASSERT_TRUE(controller.summary().realtime.has_value());
    EXPECT_EQ(controller.summary().realtime->dropped(), 0u);
    EXPECT_EQ(ReadRealtimeReport(out + "/" + kRealtimeReportFile).dropped(), 0u);
  }
  // A trajectory written with poses beyond any camera's reach (a depth scale off by orders of
  // magnitude) does not read back: the run fails (exit 1) naming it, and eval.json and the other
  // outputs are still written. Before, the read-back threw: no eval.json, no summary.
  {
    const std::string out = testing::MakeTempDir("run_controller_far");
    RunControllerOptions o = Options(dir, out);
    o.mode = RunMode::kPipeline;
    RunController controller(o, dataset, {}, [&](const RunControllerOptions& options) {
      WriteRecorderFiles(options.out, DatasetStamps(dataset, kFrames));
      std::vector<StampedPose> far;
      for (const Timestamp& t : DatasetStamps(dataset, kFrames))
        far.push_back({t, Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(5e10, 0, 0))});
      WriteTumTrajectory((options.out / "trajectory.txt").string(), far);
      return PipelineRunResult{};
    });
    EXPECT_EQ(controller.Run(), 1);
    const std::string json = testing::ReadAll(out + "/eval.json");
    EXPECT_NE(json.find("\"exit_code\": 1"), std::string::npos) << json;
    EXPECT_NE(json.find("trajectory.txt not written: written but not readable back"),
              std::string::npos)
        << json;
    EXPECT_TRUE(fs::exists(out + "/frames.csv"));
  }
}

TEST(RunControllerOptions, CheckNamesTheField) {
  RunControllerOptions o;
  o.dataset_dir = "data";
  o.out = "out";
  EXPECT_NO_THROW(o.Check());
  auto expect_invalid = [](const RunControllerOptions& bad, const std::string& field) {
    try {
      bad.Check();
      ADD_FAILURE() << "accepted: " << field;
    } catch (const InvalidOptions& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  RunControllerOptions bad = o;
  bad.rate = 0.001;
  expect_invalid(bad, "rate");
  bad = o;
  bad.first = 10;
  bad.last = 5;
  expect_invalid(bad, "last");
  bad = o;
  bad.use_detection_file = true;
  bad.mode = RunMode::kPipeline;
  expect_invalid(bad, "detections");
  bad = o;
  bad.loop_minutes = 1;
  expect_invalid(bad, "loop_minutes");
  bad = o;
  bad.out.clear();
  expect_invalid(bad, "out");
}

}  // namespace
}  // namespace dygslam
