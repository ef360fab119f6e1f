// Settings of place recognition and loop closing (YAML section `LoopClosing:`).
#pragma once

#include <cmath>
#include <string>

#include "core/base/error.h"
#include "core/slam/map/place_recognition.h"

namespace dygslam {

struct LoopClosingOptions {
  // Bag-of-words vocabulary file (`dygslam vocab`). Empty: no place recognition at all
  // (relocalization and reference-keyframe tracking match by brute force, no loop closing).
  std::string vocabulary;
  // LoopClosing.enabled: detect and close loops. On by default: on bonn_crowd_part (no revisit, no
  // loop accepted; deterministic output identical on and off) it cost nothing measurable once the
  // checks ran outside the map lock (quiet machine, 2026-12-02, threaded median of 3: ATE 0.0139
  // on vs 0.0142 m off, CPU per frame within the run-to-run spread; BENCHMARKS.md).
  // Relocalization and reference-keyframe tracking use the index either way.
  bool enabled = true;
  // Candidates: keyframes at least this many keyframes older than the query...
  int min_keyframe_gap = 10;
  // ...and not covisible with it, unless the keyframe path since them is at least this long (a
  // place revisited without losing the map, e.g. there and back; <= 0: never, as ORB-SLAM2).
  // bonn_crowd_part's whole path is 1.0 m (ground truth), its there-and-back version 2.0 m.
  double revisit_min_path_m = 1.5;
  // ...seen in this many consecutive keyframes (each one covisible with the last group).
  int consistency = 3;
  // SE3 from matched map points (metric depth): RANSAC then refinement on the inliers.
  int min_bow_matches = 20;
  int ransac_iterations = 300;
  double ransac_threshold_px = 4.0;  // reprojection error, level-0 pixels (scaled by level)
  // Acceptance: a false loop on bonn_crowd_part had 21 inliers and moved the camera
  // 0.8 m after 0.4 m of travel, so the transform must be well supported after refinement...
  int min_ransac_inliers = 40;
  double min_inlier_ratio = 0.3;    // ...by this fraction of the BoW correspondences...
  int min_projection_matches = 60;  // ...confirmed by the guided search with the loop transform...
  // ...and plausible: the correction (camera moved by the loop transform) must not exceed what
  // odometry could have drifted over the keyframe path since the loop keyframe:
  // base + per_meter * path length (translation in m, rotation in degrees).
  double max_correction_m = 0.10;
  double max_drift_per_meter = 0.10;
  double max_correction_deg = 3.0;
  double max_drift_deg_per_meter = 2.0;
  double fusion_radius_px = 4.0;
  // Essential graph: covisibility edges with at least this many shared points.
  int essential_min_weight = 100;
  int pose_graph_iterations = 20;
  // A loop whose correction is below both of these moves no keyframe: its duplicated points are
  // fused and the two sides linked (covisibility, loop edge for later pose graphs), without the
  // transform and the pose graph. On the there-and-back sequence (a map never lost) the two
  // corrections were 2-3 mm, and moving the map for them changed later tracking about as much as
  // they corrected (BENCHMARKS.md). 0 / 0: every loop runs the pose graph.
  double pose_graph_min_correction_m = 0.02;
  double pose_graph_min_correction_deg = 1.0;
  // After a loop that moved the map (above pose_graph_min_correction_*), in the background. A
  // fused-only loop moved nothing, so there is nothing for it to spread.
  bool global_bundle_adjustment = true;
  int global_ba_iterations = 10;
  PlaceRecognitionOptions place;
  void Check() const {
    DYGSLAM_CHECK_OPTION(min_keyframe_gap >= 1, "LoopClosing.min_keyframe_gap");
    DYGSLAM_CHECK_OPTION(std::isfinite(revisit_min_path_m), "LoopClosing.revisit_min_path_m");
    DYGSLAM_CHECK_OPTION(consistency >= 1, "LoopClosing.consistency");
    DYGSLAM_CHECK_OPTION(min_bow_matches >= 3, "LoopClosing.min_bow_matches");
    DYGSLAM_CHECK_OPTION(ransac_iterations >= 1, "LoopClosing.ransac_iterations");
    DYGSLAM_CHECK_OPTION(ransac_threshold_px > 0 && std::isfinite(ransac_threshold_px),
                         "LoopClosing.ransac_threshold_px");
    DYGSLAM_CHECK_OPTION(min_ransac_inliers >= 3, "LoopClosing.min_ransac_inliers");
    DYGSLAM_CHECK_OPTION(min_inlier_ratio >= 0 && min_inlier_ratio <= 1,
                         "LoopClosing.min_inlier_ratio");
    DYGSLAM_CHECK_OPTION(min_projection_matches >= min_ransac_inliers,
                         "LoopClosing.min_projection_matches");
    DYGSLAM_CHECK_OPTION(max_correction_m >= 0 && max_correction_m <= 10000,
                         "LoopClosing.max_correction_m");
    DYGSLAM_CHECK_OPTION(max_drift_per_meter >= 0 && std::isfinite(max_drift_per_meter),
                         "LoopClosing.max_drift_per_meter");
    DYGSLAM_CHECK_OPTION(max_correction_deg >= 0 && max_correction_deg <= 180,
                         "LoopClosing.max_correction_deg");
    DYGSLAM_CHECK_OPTION(max_drift_deg_per_meter >= 0 && std::isfinite(max_drift_deg_per_meter),
                         "LoopClosing.max_drift_deg_per_meter");
    DYGSLAM_CHECK_OPTION(fusion_radius_px > 0 && std::isfinite(fusion_radius_px),
                         "LoopClosing.fusion_radius_px");
    DYGSLAM_CHECK_OPTION(essential_min_weight >= 1, "LoopClosing.essential_min_weight");
    DYGSLAM_CHECK_OPTION(pose_graph_iterations >= 1, "LoopClosing.pose_graph_iterations");
    DYGSLAM_CHECK_OPTION(
        pose_graph_min_correction_m >= 0 && std::isfinite(pose_graph_min_correction_m),
        "LoopClosing.pose_graph_min_correction_m");
    DYGSLAM_CHECK_OPTION(pose_graph_min_correction_deg >= 0 && pose_graph_min_correction_deg <= 180,
                         "LoopClosing.pose_graph_min_correction_deg");
    DYGSLAM_CHECK_OPTION(global_ba_iterations >= 1, "LoopClosing.global_ba_iterations");
    place.Check();
  }
};

}  // namespace dygslam
