// The per-map-point dynamic flag (core/slam/map/dynamic_points.h) on generated sequences.
// The System runs the full filter (deterministic) on movers that walk, stop, stand and turn,
// two of the three never detected, with and without the flag. Ground truth of a map point: the
// generator's object label at the pixel of one of its observations (in the frame of that
// keyframe); a point is "dynamic" when that pixel is on a mover. Precision / recall of
// `is_dynamic` over the points in the final map plus the flagged ones (points the ordinary
// culling removed are not counted).
#include <gtest/gtest.h>

#include <cstdio>
#include <vector>

#include "core/eval/trajectory_eval.h"
#include "core/system/system.h"
#include "tools/synth/synthetic_scene.h"

namespace dygslam {
namespace {

struct PointCounts {
  int flagged_dynamic = 0, flagged_static = 0, kept_dynamic = 0, kept_static = 0;
  double Precision() const {
    const int flagged = flagged_dynamic + flagged_static;
    return flagged == 0 ? 1.0 : static_cast<double>(flagged_dynamic) / flagged;
  }
  double Recall() const {
    const int dynamic = flagged_dynamic + kept_dynamic;
    return dynamic == 0 ? 1.0 : static_cast<double>(flagged_dynamic) / dynamic;
  }
};

struct RunOutput {
  PointCounts points;
  double ate = 0;
  int poses = 0;
};

RunOutput RunGenerated(const SyntheticOptions& synth, bool flag_points) {
  const SyntheticScene scene(synth);
  SystemOptions options;
  options.camera = synth.camera;
  options.sensor = synth.sensor;
  options.filter.mode = FilterMode::kFull;
  options.dynamic_points.enabled = flag_points;
  options.deterministic = true;
  System system(options);
  std::vector<cv::Mat> labels;
  std::vector<StampedPose> truth;
  for (int i = 0; i < scene.num_frames(); ++i) {
    const SyntheticFrame f = scene.RenderFrame(i);
    // Detector boxes are looser than the silhouettes (static background inside them).
    std::vector<Detection> boxes = f.boxes;
    for (Detection& d : boxes)
      d.box = cv::Rect2f(d.box.x - 20, d.box.y - 20, d.box.width + 40, d.box.height + 40) &
              cv::Rect2f(0, 0, static_cast<float>(f.rgb.cols), static_cast<float>(f.rgb.rows));
    system.FeedRgbdFrame(f.rgb, f.depth, f.stamp, cv::Mat(), &boxes);
    labels.push_back(f.object_labels);
    truth.push_back(StampedPose{scene.FrameStamp(i), scene.WorldFromCam(i)});
  }
  system.Shutdown();
  RunOutput out;
  for (const MapPointLabel& p : system.MapPointLabels()) {
    if (p.frame_id < 0 || p.frame_id >= static_cast<int64_t>(labels.size())) continue;
    const cv::Mat& l = labels[p.frame_id];
    const cv::Point px(cvRound(p.pixel.x), cvRound(p.pixel.y));
    if (px.x < 0 || px.y < 0 || px.x >= l.cols || px.y >= l.rows) continue;
    const bool dynamic = l.at<uint8_t>(px) != 0;
    out.points.flagged_dynamic += p.is_dynamic && dynamic;
    out.points.flagged_static += p.is_dynamic && !dynamic;
    out.points.kept_dynamic += !p.is_dynamic && dynamic;
    out.points.kept_static += !p.is_dynamic && !dynamic;
  }
  const std::vector<StampedPose> trajectory = system.Trajectory();
  out.poses = static_cast<int>(trajectory.size());
  out.ate = ComputeAte(truth, trajectory).error.rmse;
  return out;
}

SyntheticOptions Walkers(int seed) {
  SyntheticOptions o;
  o.num_frames = 60;
  o.num_moving_objects = 3;
  o.num_undetected_objects = 2;
  o.object_speed = 0.6;
  o.object_pause = 1.0;
  o.object_turn = true;
  o.supersampling = 1;
  o.seed = seed;
  o.depth_noise = true;
  o.path_amplitude = 0.1;
  o.yaw_amplitude_deg = 10;
  o.pitch_amplitude_deg = 3;
  o.roll_amplitude_deg = 1;
  return o;
}

TEST(DynamicMapPoints, FlaggedPointsAreOnMovers) {
  const SyntheticOptions synth = Walkers(5);
  const RunOutput off = RunGenerated(synth, false);
  const RunOutput on = RunGenerated(synth, true);
  for (const auto& [name, r] : {std::pair<const char*, const RunOutput&>{"off", off}, {"on", on}})
    std::printf(
        "map points, flag %s: flagged %d (on movers %d) kept %d (on movers %d): precision %.3f "
        "recall %.3f; ATE %.4f m over %d poses\n",
        name, r.points.flagged_dynamic + r.points.flagged_static, r.points.flagged_dynamic,
        r.points.kept_dynamic + r.points.kept_static, r.points.kept_dynamic, r.points.Precision(),
        r.points.Recall(), r.ate, r.poses);
  ASSERT_EQ(off.points.flagged_dynamic + off.points.flagged_static, 0);
  ASSERT_GE(on.points.flagged_dynamic + on.points.kept_dynamic, 8)
      << "too few map points on movers to measure";
  EXPECT_EQ(on.poses, synth.num_frames);
  // Measured (seed 5, 60 frames, two of the three movers never detected, deterministic,
  // depth-based labels): 27 flagged, 25 of them on movers (precision 0.93), 2 mover points left
  // in the map (recall 0.93); without the flag the final map holds 2 mover points (the filter's
  // labels already keep almost every mover feature out). ATE 0.0125 m with the flag, 0.0126 m
  // without. (With one undetected mover the map now gets 3 mover points in all, too few to
  // measure: keyframes are no longer made for the features kept in the movers' boxes.)
  EXPECT_GE(on.points.flagged_dynamic, 8);
  EXPECT_GE(on.points.Precision(), 0.85);
  EXPECT_GE(on.points.Recall(), 0.8);
  EXPECT_LE(on.ate, 0.015);
}

}  // namespace
}  // namespace dygslam
