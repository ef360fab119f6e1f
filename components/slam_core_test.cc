// SlamCore without DDS: real Bonn frames in, frame results and keyframes out; the depth of a frame
// in another scale than the settings' DepthMapFactor is handed to the System in metres.
#include "components/slam_core.h"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <memory>
#include <set>

#include "core/config/settings.h"
#include "core/dynamic/yolo_detector.h"
#include "core/io/dataset.h"
#include "run/settings_table.h"
#include "run/system_config.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {

SystemOptions BonnSystemOptions() {
  SystemOptions system = SystemOptionsFromSettings(
      LoadSettings(std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/bonn.yaml"));
  system.filter.mode = FilterMode::kGeometry;  // no detector needed
  system.deterministic = true;
  return system;
}

RgbdFrameData LoadFrame(const RgbdDataset& dataset, const PinholeCamera& camera, size_t entry) {
  const auto index = dataset.FrameForRgbEntry(entry);
  EXPECT_TRUE(index) << "rgb.txt entry " << entry << " has no depth partner";
  RgbdFrameData frame;
  frame.stamp = dataset.frame(*index).rgb_stamp;
  frame.seq = entry;
  frame.camera = camera;
  frame.rgb = dataset.LoadRgb(*index);
  frame.depth = dataset.LoadDepth(*index);
  return frame;
}

constexpr size_t kFrames = 50;

TEST(SlamCore, TracksRealFramesAndEmitsKeyframes) {
  DYGSLAM_REQUIRE_DATASET(dir, "bonn_crowd_part");
  const RgbdDataset dataset = RgbdDataset::Open(dir);
  SlamComponentOptions options;
  options.system = BonnSystemOptions();
  SlamCore core(options);
  size_t tracked = 0;
  std::set<int64_t> keyframe_ids;
  for (size_t k = 0; k < kFrames; ++k) {
    const RgbdFrameData frame = LoadFrame(dataset, options.system.camera, k);
    const SlamOutput out = core.Process(frame, nullptr);
    EXPECT_EQ(out.result.stamp, frame.stamp);
    if (out.result.world_from_cam) ++tracked;
    for (const KeyframeData& keyframe : out.keyframes) {
      if (!keyframe.pose_update_only && !keyframe.removed) {
        keyframe_ids.insert(keyframe.id);
        // A new keyframe carries what the map needs: the image, depth in metres.
        EXPECT_EQ(keyframe.depth.type(), CV_32FC1);
        EXPECT_EQ(keyframe.rgb.size(), frame.rgb.size());
      }
    }
    if (k == 0) {
      // The first frame initialises the map: it is the first keyframe, at the origin.
      ASSERT_TRUE(out.result.world_from_cam);
      EXPECT_LT(out.result.world_from_cam->translation.norm(), 1e-9);
      EXPECT_EQ(keyframe_ids.size(), 1u);
    }
  }
  core.Finish();
  EXPECT_TRUE(core.Finish().empty()) << "a second Finish() has nothing more to emit";
  // Measured: the first 50 crowd frames are all tracked (the person enters later); keyframes at
  // frames 0, 42, 44 and 48 (the camera turns; before that the first keyframe holds the view).
  EXPECT_EQ(tracked, kFrames);
  EXPECT_EQ(core.Trajectory().size(), tracked);
  EXPECT_GE(keyframe_ids.size(), 2u);
  EXPECT_EQ(core.KeyframeTrajectory().size(), keyframe_ids.size());
}

// The same frames with depth in the settings' scale (raw, passed through) and with the settings
// expecting another scale (SlamCore converts to metres): the same trajectory.
TEST(SlamCore, DepthInAnotherScaleIsConvertedToMetres) {
  DYGSLAM_REQUIRE_DATASET(dir, "bonn_crowd_part");
  const RgbdDataset dataset = RgbdDataset::Open(dir);
  SlamComponentOptions raw_options;
  raw_options.system = BonnSystemOptions();
  SlamComponentOptions converted_options = raw_options;
  converted_options.system.sensor.depth_map_factor = 1000.0;  // e.g. a millimetre camera
  ASSERT_NE(raw_options.system.sensor.depth_map_factor, 1000.0);
  SlamCore raw(raw_options);
  SlamCore converted(converted_options);
  for (size_t k = 0; k < 15; ++k) {
    RgbdFrameData frame = LoadFrame(dataset, raw_options.system.camera, k);
    frame.depth_scale = raw_options.system.sensor.depth_map_factor;  // what the player sends
    raw.Process(frame, nullptr);
    converted.Process(frame, nullptr);
  }
  raw.Finish();
  converted.Finish();
  const std::vector<StampedPose> a = raw.Trajectory();
  const std::vector<StampedPose> b = converted.Trajectory();
  ASSERT_EQ(a.size(), b.size());
  ASSERT_GE(a.size(), 10u);
  double max_difference = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].stamp, b[i].stamp);
    max_difference = std::max(
        max_difference, (a[i].world_from_cam.translation - b[i].world_from_cam.translation).norm());
  }
  // Raw / factor in the System and raw / scale here differ by float rounding only (measured 0;
  // a wrong scale moves the camera by centimetres over these frames).
  EXPECT_LT(max_difference, 1e-4);
}

TEST(SlamCore, NeedsDetectionsOnlyForBoxFiltersFedFromOutside) {
  SlamComponentOptions options;
  options.system.filter.mode = FilterMode::kFull;
  EXPECT_TRUE(options.NeedsDetections());
  options.system.filter.mode = FilterMode::kBoxes;
  EXPECT_TRUE(options.NeedsDetections());
  options.system.filter.mode = FilterMode::kGeometry;
  EXPECT_FALSE(options.NeedsDetections());
  options.system.filter.mode = FilterMode::kNone;
  EXPECT_FALSE(options.NeedsDetections());
  options.system.filter.mode = FilterMode::kFull;
  options.external_detections = false;  // the System runs its own detector
  EXPECT_FALSE(options.NeedsDetections());
}

// The DDS path of the detector cadence: the detector component detects every
// 3rd frame, slam feeds the others with carried boxes (detector_skipped). A keyframe made on such
// a frame gets its map mask from slam's own detector (SystemOptions::detect_skipped_keyframes, the
// detector component's options as the pipeline sets them), as `--direct` does; tracking keeps
// the carried boxes. rgb.txt entries 100-145 of bonn_crowd_part: people walk through the view.
struct SkippedKeyframeRun {
  std::vector<FrameResult> results;
  std::vector<KeyframeData> keyframes;  // new keyframes only
  std::set<int64_t> skipped_stamps;  // stamps (ns) of the frames the "detector component" skipped
};

SkippedKeyframeRun RunCadenceThroughSlamCore(const RgbdDataset& dataset, YoloDetector* component,
                                             const DetectorOptions& detector_options,
                                             bool detect_skipped_keyframes) {
  SlamComponentOptions options;
  options.system = BonnSystemOptions();
  options.system.filter.mode = FilterMode::kFull;
  options.system.detection_every_n_frames = 3;
  options.system.detector = detector_options;
  options.system.detect_skipped_keyframes = detect_skipped_keyframes;
  SlamCore core(options);
  SkippedKeyframeRun run;
  for (size_t entry = 100; entry < 145; ++entry) {
    const RgbdFrameData frame = LoadFrame(dataset, options.system.camera, entry);
    SlamOutput out;
    if (entry % 3 == 0) {  // FramePairer's cadence: seq % n == 0 (seq = entry here)
      const std::vector<Detection> boxes = component->Detect(frame.rgb);
      out = core.Process(frame, &boxes);
    } else {
      run.skipped_stamps.insert(frame.stamp.nanoseconds());
      out = core.Process(frame, nullptr, /*detector_skipped=*/true);
    }
    run.results.push_back(out.result);
    for (KeyframeData& k : out.keyframes)
      if (!k.pose_update_only && !k.removed) run.keyframes.push_back(std::move(k));
  }
  for (KeyframeData& k : core.Finish())
    if (!k.pose_update_only && !k.removed) run.keyframes.push_back(std::move(k));
  return run;
}

// The detector component's options (components/pipeline.cc: DetectorOptionsFor).
DetectorOptions ComponentDetectorOptions() {
  DetectorOptions options = DetectorOptionsForModel("yolo-fastest-1.1");
  options.num_threads = 1;
  return options;
}

bool SameBoxes(const std::vector<Detection>& a, const std::vector<Detection>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i)
    if (a[i].box != b[i].box || a[i].score != b[i].score || a[i].class_id != b[i].class_id)
      return false;
  return true;
}

TEST(SlamCore, KeyframesOnFramesTheDetectorComponentSkippedGetDetectedBoxes) {
  DYGSLAM_REQUIRE_DATASET(dir, "bonn_crowd_part");
  DYGSLAM_REQUIRE_MODELS(models);
  const RgbdDataset dataset = RgbdDataset::Open(dir);
  const DetectorOptions detector_options = ComponentDetectorOptions();
  const std::unique_ptr<YoloDetector> component = YoloDetector::Create(detector_options);
  const SkippedKeyframeRun detected =
      RunCadenceThroughSlamCore(dataset, component.get(), detector_options, true);
  const SkippedKeyframeRun carried =
      RunCadenceThroughSlamCore(dataset, component.get(), detector_options, false);
  // Tracking is the same either way: the fresh boxes go to the map only.
  ASSERT_EQ(detected.results.size(), carried.results.size());
  for (size_t i = 0; i < detected.results.size(); ++i) {
    EXPECT_EQ(detected.results[i].detections_carried,
              detected.skipped_stamps.count(detected.results[i].stamp.nanoseconds()) > 0)
        << i;
    ASSERT_TRUE(detected.results[i].world_from_cam && carried.results[i].world_from_cam) << i;
    EXPECT_TRUE(detected.results[i].world_from_cam->translation ==
                carried.results[i].world_from_cam->translation)
        << i;
  }
  ASSERT_EQ(detected.keyframes.size(), carried.keyframes.size());
  int on_skipped = 0, carried_differ = 0;
  for (size_t i = 0; i < detected.keyframes.size(); ++i) {
    const KeyframeData& k = detected.keyframes[i];
    ASSERT_EQ(k.stamp, carried.keyframes[i].stamp);
    const std::vector<Detection> own = component->Detect(k.rgb);
    if (!detected.skipped_stamps.count(k.stamp.nanoseconds())) {  // the component's own boxes
      EXPECT_TRUE(SameBoxes(k.detections, own)) << k.stamp.ToString();
      EXPECT_TRUE(SameBoxes(carried.keyframes[i].detections, own)) << k.stamp.ToString();
      continue;
    }
    ++on_skipped;
    EXPECT_TRUE(SameBoxes(k.detections, own)) << "keyframe at " << k.stamp.ToString();
    if (!SameBoxes(carried.keyframes[i].detections, own) ||
        cv::countNonZero(k.dynamic_mask != carried.keyframes[i].dynamic_mask) > 0)
      ++carried_differ;
  }
  std::cout << detected.keyframes.size() << " keyframes, " << on_skipped << " on skipped frames, "
            << carried_differ << " of them with other boxes or masks"
            << " when carried\n";
  // The stretch has keyframes on skipped frames, and there the carried boxes are not the
  // detector's (else this test could not see the carried boxes come back).
  EXPECT_GT(on_skipped, 0);
  EXPECT_GT(carried_differ, 0);
}

// The same on a slam host without the model (the detector component on another host): the
// keyframes keep the carried boxes for their masks (a warning), the run goes on.
TEST(SlamCore, KeyframesOfSkippedFramesKeepCarriedBoxesWithoutAModel) {
  DYGSLAM_REQUIRE_DATASET(dir, "bonn_crowd_part");
  DYGSLAM_REQUIRE_MODELS(models);
  const RgbdDataset dataset = RgbdDataset::Open(dir);
  const DetectorOptions detector_options = ComponentDetectorOptions();
  const std::unique_ptr<YoloDetector> component = YoloDetector::Create(detector_options);
  DetectorOptions missing = detector_options;
  missing.cfg_path = testing::MakeTempDir("slam_core_no_model") + "/missing.cfg";
  const SkippedKeyframeRun without_model =
      RunCadenceThroughSlamCore(dataset, component.get(), missing, true);
  const SkippedKeyframeRun carried =
      RunCadenceThroughSlamCore(dataset, component.get(), detector_options, false);
  ASSERT_EQ(without_model.keyframes.size(), carried.keyframes.size());
  int on_skipped = 0;
  for (size_t i = 0; i < carried.keyframes.size(); ++i) {
    const KeyframeData& k = without_model.keyframes[i];
    if (without_model.skipped_stamps.count(k.stamp.nanoseconds())) ++on_skipped;
    EXPECT_TRUE(SameBoxes(k.detections, carried.keyframes[i].detections)) << k.stamp.ToString();
    EXPECT_EQ(cv::countNonZero(k.dynamic_mask != carried.keyframes[i].dynamic_mask), 0);
  }
  EXPECT_GT(on_skipped, 0);
}

TEST(SlamCore, BadOptionsAreRefusedByName) {
  SlamComponentOptions options;
  options.system = BonnSystemOptions();
  EXPECT_NO_THROW(options.Check());
  options.carry_forward_max_frames = -1;
  try {
    options.Check();
    FAIL() << "Check() accepted carry_forward_max_frames = -1";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("slam.carry_forward_max_frames"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace dygslam
