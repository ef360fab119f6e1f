// Per-feature dynamic labels on generated sequences with the hard cases of real data:
// movers that walk, stop, stand and turn; static background inside their (padded) boxes at other
// depths; a mover that is never detected; a mover filling half the view; a slowly moving camera.
// Ground truth: a feature is dynamic when its pixel belongs to a mover (object_labels != 0).
#include "core/dynamic/label_evaluation.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <map>
#include <opencv2/imgproc.hpp>

#include "core/base/error.h"
#include "core/dynamic/dynamic_filter.h"
#include "core/slam/feature/orb_extractor.h"
#include "tools/synth/synthetic_scene.h"

namespace dygslam {
namespace {

TEST(LabelEvaluation, CountsEveryCaseOnAHandmadeLabelImage) {
  cv::Mat labels = cv::Mat::zeros(100, 100, CV_8UC1);
  labels(cv::Rect(50, 0, 50, 100)).setTo(1);  // mover 0 on the right half
  labels(cv::Rect(0, 80, 20, 20)).setTo(2);   // mover 1 (undetected) bottom left
  std::vector<cv::KeyPoint> kps;
  for (cv::Point2f p :
       {cv::Point2f(10, 10), cv::Point2f(30, 10), cv::Point2f(60, 10), cv::Point2f(80, 50),
        cv::Point2f(10, 90), cv::Point2f(48, 10), cv::Point2f(200, 5)})
    kps.emplace_back(p, 7.f);
  //                           static static mover mover undet. static(edge) outside
  const std::vector<uint8_t> flags = {0, 1, 1, 0, 1, 0, 1};
  const std::vector<uint8_t> region = {0, 1, 1, 1, 0, 1, 0};
  const LabelCounts c = EvaluateLabels(kps, flags, region, labels, {2});
  EXPECT_EQ(c.true_positives, 2);   // (60,10), (10,90)
  EXPECT_EQ(c.false_positives, 1);  // (30,10)
  EXPECT_EQ(c.false_negatives, 1);  // (80,50)
  EXPECT_EQ(c.true_negatives, 2);   // (10,10), (48,10)
  EXPECT_EQ(c.static_in_region, 2);
  EXPECT_EQ(c.static_in_region_kept, 1);
  EXPECT_EQ(c.undetected, 1);
  EXPECT_EQ(c.undetected_flagged, 1);
  EXPECT_EQ(c.ignored, 1);  // outside the image
  EXPECT_DOUBLE_EQ(c.Precision(), 2.0 / 3.0);
  EXPECT_DOUBLE_EQ(c.Recall(), 2.0 / 3.0);
  // With a boundary band, the static feature 2 px from the mover is ambiguous.
  LabelEvaluationOptions band;
  band.boundary_px = 3;
  EXPECT_EQ(EvaluateLabels(kps, flags, region, labels, {2}, band).ignored, 2);
  EXPECT_THROW(EvaluateLabels(kps, {0, 1}, region, labels, {}), InvalidOptions);
  EXPECT_THROW(EvaluateLabels(kps, flags, region, cv::Mat(), {}), InvalidOptions);
}

// One generated sequence, rendered and ORB-extracted once, then run through each configuration.
struct PreparedFrame {
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  std::vector<float> depths;
  cv::Mat depth;  // CV_32FC1 metres
  std::vector<Detection> boxes;
  cv::Mat labels;
};

struct Prepared {
  std::vector<PreparedFrame> frames;
  std::vector<int> undetected_labels;
  cv::Matx33d camera_matrix;
};

Prepared Prepare(const SyntheticOptions& options) {
  const SyntheticScene scene(options);
  Prepared out;
  out.camera_matrix = cv::Matx33d(options.camera.K());
  for (int k = 0; k < scene.num_moving_objects(); ++k)
    if (!scene.IsObjectDetected(k)) out.undetected_labels.push_back(k + 1);
  const OrbExtractor extractor{OrbExtractorOptions()};
  for (int f = 0; f < options.num_frames; ++f) {
    const SyntheticFrame frame = scene.RenderFrame(f);
    cv::Mat gray;
    cv::cvtColor(frame.rgb, gray, cv::COLOR_BGR2GRAY);
    const OrbFeatures features = extractor.Extract(gray);
    PreparedFrame p;
    p.keypoints = features.keypoints;
    p.descriptors = features.DescriptorMatrix();
    frame.depth.convertTo(p.depth, CV_32F, 1.0 / options.sensor.depth_map_factor);
    for (const cv::KeyPoint& kp : p.keypoints) {
      const uint16_t raw = frame.depth.at<uint16_t>(cvRound(kp.pt.y), cvRound(kp.pt.x));
      p.depths.push_back(static_cast<float>(raw / options.sensor.depth_map_factor));
    }
    // Detector boxes are looser than the silhouettes: pad the ground-truth boxes by 20 px, so
    // the dynamic region holds static background at other depths, as with a real detector.
    constexpr float kPad = 20.f;
    for (Detection d : frame.boxes) {
      d.box =
          cv::Rect2f(d.box.x - kPad, d.box.y - kPad, d.box.width + 2 * kPad,
                     d.box.height + 2 * kPad) &
          cv::Rect2f(0, 0, static_cast<float>(frame.rgb.cols), static_cast<float>(frame.rgb.rows));
      p.boxes.push_back(d);
    }
    p.labels = frame.object_labels;
    out.frames.push_back(std::move(p));
  }
  return out;
}

// The configurations of `--filter` as System sets them up (core/system ApplyFilterConfiguration).
DynamicFilterOptions Configuration(const std::string& name) {
  DynamicFilterOptions o;
  if (name == "boxes") o.mode = FilterMode::kBoxes;
  if (name == "geometry") o.mode = FilterMode::kGeometry;
  if (name == "geometry-epipolar") {  // geometry mode with the paper's epipolar test
    o.mode = FilterMode::kGeometry;
    o.depth_residual = false;
  }
  if (name == "paper") {
    o.box_margin_fraction = 0;
    o.depth_residual = false;
  }
  // Ablation of full: before it (the paper's epipolar test in full), without the
  // depth-refined boxes, with the chained frame-to-frame motion instead of fixed anchors.
  if (name == "full-epipolar") o.depth_residual = false;
  if (name == "full-no-box-depth") o.box_depth_band = 0;
  if (name == "full-chained") o.world_anchors = false;
  if (name == "full-no-consensus") o.consensus_radius = 0;
  if (name == "full-no-expand-outside") o.expand_outside = false;
  if (name == "full-planar-as-line") o.planar_residual_to_line = false;
  if (name == "geometry-chained") {
    o.mode = FilterMode::kGeometry;
    o.world_anchors = false;
  }
  if (name == "geometry-planar-as-line") {
    o.mode = FilterMode::kGeometry;
    o.planar_residual_to_line = false;
  }
  // Extra keys after '+' for one-key variations: "full+consensus_radius=70+outside_p_init=0.45"
  // (LABEL_CONFIGS=a,b,... runs only those and prints their counts; the checks then fail).
  size_t plus = name.find('+');
  while (plus != std::string::npos) {
    const size_t next = name.find('+', plus + 1);
    const std::string kv =
        name.substr(plus + 1, next == std::string::npos ? next : next - plus - 1);
    const std::string key = kv.substr(0, kv.find('='));
    const double v = std::stod(kv.substr(kv.find('=') + 1));
    if (key == "consensus_radius") o.consensus_radius = v;
    if (key == "consensus_depth_gap") o.consensus_depth_gap = v;
    if (key == "consensus_min_neighbours") o.consensus_min_neighbours = static_cast<int>(v);
    if (key == "box_depth_band") o.box_depth_band = v;
    if (key == "outside_p_init") o.outside_p_init = v;
    if (key == "depth_residual_scale") o.depth_residual_scale = v;
    if (key == "anchor_max_age") o.anchor_max_age = static_cast<int>(v);
    if (key == "pnp_threshold") o.pnp_threshold = v;
    if (key == "threshold") o.threshold = v;
    if (key == "expand_outside") o.expand_outside = v != 0;
    plus = next;
  }
  return o;  // "full": the defaults
}

LabelCounts Run(const Prepared& data, const std::string& configuration) {
  DynamicFilter filter(Configuration(configuration));
  LabelCounts total;
  for (size_t f = 0; f < data.frames.size(); ++f) {
    const PreparedFrame& p = data.frames[f];
    FilterInput input(p.keypoints, p.descriptors, p.boxes);
    input.depths = &p.depths;
    input.camera_matrix = &data.camera_matrix;
    input.depth_image = &p.depth;
    const FilterResult r = filter.Process(input);
    if (f == 0) continue;  // no previous frame: the geometry cannot say anything yet
    std::vector<uint8_t> region(r.features.size());
    for (size_t i = 0; i < region.size(); ++i)
      region[i] = r.features[i].in_dynamic_region && configuration.rfind("geometry", 0) != 0;
    total +=
        EvaluateLabels(p.keypoints, r.DynamicFlags(), region, p.labels, data.undetected_labels);
  }
  return total;
}

std::map<std::string, LabelCounts> RunAll(const Prepared& data, const char* scenario) {
  std::map<std::string, LabelCounts> out;
  std::vector<std::string> names = {"boxes",
                                    "geometry-epipolar",
                                    "geometry-chained",
                                    "geometry-planar-as-line",
                                    "geometry",
                                    "paper",
                                    "full-epipolar",
                                    "full-no-box-depth",
                                    "full-chained",
                                    "full-no-consensus",
                                    "full-no-expand-outside",
                                    "full-planar-as-line",
                                    "full"};
  if (const char* only = std::getenv("LABEL_CONFIGS")) {
    names.clear();
    std::string list = only;
    for (size_t a = 0; a <= list.size();) {
      size_t b = list.find(',', a);
      if (b == std::string::npos) b = list.size();
      names.push_back(list.substr(a, b - a));
      a = b + 1;
    }
  }
  for (const std::string& name : names) {
    out[name] = Run(data, name);
    std::printf("%s %-17s %s\n", scenario, name.c_str(), out[name].ToString().c_str());
  }
  return out;
}

// Slow camera, three movers at 0.6 m/s that stop, stand and turn at the ends of their lanes,
// the farthest never detected; depth noise.
SyntheticOptions WalkersOptions() {
  SyntheticOptions o;
  o.num_frames = 60;
  o.num_moving_objects = 3;
  o.num_undetected_objects = 1;
  o.object_speed = 0.6;
  o.object_pause = 1.0;
  o.object_turn = true;
  o.supersampling = 1;
  o.seed = 5;
  o.depth_noise = true;
  o.path_amplitude = 0.1;
  o.yaw_amplitude_deg = 10;
  o.pitch_amplitude_deg = 3;
  o.roll_amplitude_deg = 1;
  return o;
}

TEST(DynamicLabelsSynthetic, WalkersStopTurnAndOneIsNeverDetected) {
  const Prepared data = Prepare(WalkersOptions());
  const auto c = RunAll(data, "walkers");
  ASSERT_GT(c.at("boxes").NumDynamic(), 300) << "too few features on movers to measure";
  ASSERT_GT(c.at("boxes").undetected, 50) << "the undetected mover is hardly visible";
  // Measured (seed 5, 59 frames scored; ORB of core/slam, deterministic):
  //   boxes             precision 0.51 recall 0.71 undetected 0.21 (where it overlaps a box)
  //   geometry-epipolar precision 0.63 recall 0.59 undetected 0.48   (the paper's test alone)
  //   geometry-chained  precision 0.91 recall 0.47 undetected 0.71   (anchors moved frame to frame)
  //   geometry-planar-as-line precision 0.87 recall 0.79 undetected 0.93 (2-D residual as 1-D)
  //   geometry          precision 0.99 recall 0.72 undetected 0.90   (anchors fixed, consensus)
  //   paper             precision 0.88 recall 0.41 static-in-box kept 0.86 undetected 0.08
  //   full-epipolar     precision 0.92 recall 0.42 static-in-box kept 0.94 undetected 0.18
  //   full-no-box-depth precision 0.988 recall 0.994 static-in-box kept 0.983 undetected 0.986
  //   full-chained      precision 0.988 recall 0.985 static-in-box kept 0.993 undetected 0.959
  //   full-no-consensus precision 0.92 recall 0.98 static-in-box kept 0.97 undetected 0.95
  //   full-no-expand-outside precision 0.99 recall 0.75 static-in-box kept 0.99 undetected 0.33
  //   full-planar-as-line precision 0.992 recall 0.995 static-in-box kept 0.990 undetected 0.987
  //   full              precision 0.994 recall 0.984 static-in-box kept 0.992 undetected 0.958
  // The planar-to-line conversion of the residual (kPlanarToLineResidual) removes most of the
  // static features flagged by noise; it takes over most of what the fixed anchors did for
  // precision in full mode (full-chained is within 0.01 of full) and part of the consensus'.
  // What it costs: the slower part of the movers' motion (geometry recall 0.79 -> 0.72, the
  // undetected mover 0.99 -> 0.96 in full).
  // Standing movers are dynamic by label but still: no motion test sees them; without the
  // expansion outside the boxes each new track on the undetected mover starts again from
  // outside_p_init and needs a few frames of motion to cross 0.5.
  const LabelCounts& full = c.at("full");
  const LabelCounts& geometry = c.at("geometry");
  EXPECT_EQ(c.at("boxes").static_in_region_kept, 0);
  EXPECT_LT(c.at("boxes").UndetectedRecall(), 0.3);
  EXPECT_GE(full.Precision(), 0.97);
  EXPECT_GE(full.Recall(), 0.97);
  EXPECT_GE(full.StaticInBoxKept(), 0.96);
  EXPECT_GE(full.UndetectedRecall(), 0.95);
  // The depth-residual test doubles full's recall; the neighbour consensus and the planar-to-line
  // conversion remove most false positives; the expansion outside the boxes catches the
  // undetected mover; in geometry mode the fixed anchors raise recall by a half.
  EXPECT_GT(full.Recall(), c.at("full-epipolar").Recall() + 0.3);
  EXPECT_GT(full.Precision(), c.at("full-no-consensus").Precision() + 0.05);
  EXPECT_GE(full.Precision(), c.at("full-chained").Precision());
  EXPECT_GT(full.UndetectedRecall(), c.at("full-no-expand-outside").UndetectedRecall() + 0.4);
  EXPECT_GE(geometry.Precision(), 0.97);
  EXPECT_GE(geometry.Recall(), 0.72);
  EXPECT_GE(geometry.UndetectedRecall(), 0.85);
  EXPECT_GT(geometry.Precision(), c.at("geometry-planar-as-line").Precision() + 0.1);
  EXPECT_GT(geometry.Precision(), c.at("geometry-chained").Precision() + 0.05);
  EXPECT_GT(geometry.Recall(), c.at("geometry-chained").Recall() + 0.2);
  EXPECT_GT(geometry.UndetectedRecall(), c.at("geometry-epipolar").UndetectedRecall() + 0.3);
}

// A mover passing close in front of a slow camera: it fills about half the view.
TEST(DynamicLabelsSynthetic, MoverFillingHalfTheView) {
  SyntheticOptions o = WalkersOptions();
  o.num_moving_objects = 1;
  o.num_undetected_objects = 0;
  o.near_object_distance = 0.75;
  o.object_speed = 0.8;
  o.object_pause = 0.5;
  o.seed = 9;
  const Prepared data = Prepare(o);
  const auto c = RunAll(data, "near");
  ASSERT_GT(c.at("boxes").NumDynamic(), 300) << "the near mover is hardly visible";
  // Measured (seed 9): boxes precision 0.43 recall 1.00; geometry-epipolar 0.54 / 0.90;
  // geometry-chained 0.978 / 0.949; geometry-planar-as-line 0.949 / 0.990; geometry 0.980 /
  // 0.980; paper 0.63 / 0.72 (static-in-box kept 0.42); full-epipolar 0.61 / 0.64 (0.69);
  // full-no-box-depth 0.966 / 1.00 (0.974); full-chained 0.979 / 0.997 (0.984);
  // full-no-consensus 0.83 / 0.995 (0.92); full-no-expand-outside 0.980 / 0.997 (0.985);
  // full-planar-as-line 0.951 / 0.997 (0.965); full 0.979 / 0.997 (0.984).
  const LabelCounts& full = c.at("full");
  EXPECT_GE(full.Precision(), 0.93);
  EXPECT_GE(full.Recall(), 0.95);
  EXPECT_GE(full.StaticInBoxKept(), 0.93);
  // The neighbour consensus and the planar-to-line conversion drop the isolated flags on the
  // background around the near mover; the fixed anchors add recall.
  EXPECT_GT(full.Precision(), c.at("full-no-consensus").Precision() + 0.12);
  EXPECT_GT(full.Precision(), c.at("full-planar-as-line").Precision() + 0.02);
  EXPECT_GE(c.at("geometry").Recall(), 0.93);
  EXPECT_GT(c.at("geometry").Recall(), c.at("geometry-epipolar").Recall() + 0.03);
  EXPECT_GE(c.at("geometry").Precision(), c.at("geometry-chained").Precision());
  EXPECT_GT(c.at("geometry").Recall(), c.at("geometry-chained").Recall() + 0.02);
}

}  // namespace
}  // namespace dygslam
