#include "run/settings_table.h"

#include "mapping/octomap_settings.h"
#include "run/system_config.h"

namespace dygslam {
namespace {

// The required keys only: everything else keeps its default while the tables read.
constexpr const char* kRequiredOnly =
    "Camera.fx: 500\nCamera.fy: 500\nCamera.cx: 319.5\nCamera.cy: 239.5\n"
    "Camera.k1: 0\nCamera.k2: 0\nCamera.p1: 0\nCamera.p2: 0\n";

Settings ReadAll(ConfigReader reader, const SettingsReadOptions& read_options) {
  Settings keys;
  keys.reader = reader;
  CheckUnknownSettingsKeys(KnownSettingsKeys(), RetiredSettingsKeys(), read_options, &keys);
  Settings settings = ReadCameraSettings(std::move(reader));
  settings.warnings = std::move(keys.warnings);
  return settings;
}

}  // namespace

const std::vector<std::pair<std::string, std::string>>& RetiredSettingsKeys() {
  static const char* const kTrackingFixed =
      "a fixed part of tracking (the value it had), not a setting of the camera or the run";
  static const char* const kLocalMappingFixed =
      "a fixed part of local mapping (the value it had), not a setting of the camera or the run";
  static const char* const kLoopClosingFixed =
      "a fixed part of loop detection and correction (the value it had); LoopClosing.enabled, "
      "max_correction_m and global_bundle_adjustment remain";
  static const char* const kDynamicFilterFixed =
      "a fixed part of our filter's extensions (the value it had); the paper's parameters and the "
      "switches of the extensions remain";
  static const char* const kOctoMapFixed =
      "a fixed part of the map builder (the value it had), not a setting of the map";
  static const std::vector<std::pair<std::string, std::string>> kKeys = {
      {"Tracking.handoff_wait_ms", "local mapping's results land at a fixed frame instead"},
      {"Tracking.keyframe_wait_ms", "local mapping's results land at a fixed frame instead"},
      {"Tracking.keyframe_weak_inliers", "measured no better; weak frames are re-anchored"},
      {"Tracking.fallback_smoothing_dense_weight",
       "measured no better; the correction is spread evenly over the stretch"},
      {"LocalMapping.final_ba_iterations", "measured no better; loop closing runs a global BA"},
      {"DynamicFilter.depth_residual_weight",
       "measured worse: the depth noise outweighs the depth term"},
      {"OctoMap.discretize", "measured no better; every ray is cast"},
      {"OctoMap.voxel_filter_size",
       "the voxel filter's cell is the map's resolution (OctoMap.resolution); "
       "OctoMap.use_voxel_filter turns it off"},
      {"LoopClosing.global_ba_min_correction_m", "a global BA follows every loop it corrects"},
      {"LoopClosing.global_ba_min_correction_deg", "a global BA follows every loop it corrects"},
      {"Tracking.motion_radius_px", kTrackingFixed},
      {"Tracking.ref_ratio", kTrackingFixed},
      {"Tracking.keyframe_counts_odometry_points", kTrackingFixed},
      {"Tracking.keyframe_min_map_inliers", kTrackingFixed},
      {"Tracking.localization_local_keyframes", kTrackingFixed},
      {"Tracking.fallback_check_below_inliers", kTrackingFixed},
      {"Tracking.fallback_min_inlier_fraction", kTrackingFixed},
      {"Tracking.fallback_min_inliers", kTrackingFixed},
      {"Tracking.fallback_override_fraction_gain", kTrackingFixed},
      {"Tracking.fallback_smoothing_weak_inliers", kTrackingFixed},
      {"LocalMapping.ba_lag_frames", kLocalMappingFixed},
      {"LocalMapping.triangulation_neighbors", kLocalMappingFixed},
      {"LocalMapping.redundancy_ratio", kLocalMappingFixed},
      {"LoopClosing.min_keyframe_gap", kLoopClosingFixed},
      {"LoopClosing.consistency", kLoopClosingFixed},
      {"LoopClosing.min_bow_matches", kLoopClosingFixed},
      {"LoopClosing.ransac_iterations", kLoopClosingFixed},
      {"LoopClosing.ransac_threshold_px", kLoopClosingFixed},
      {"LoopClosing.min_ransac_inliers", kLoopClosingFixed},
      {"LoopClosing.min_inlier_ratio", kLoopClosingFixed},
      {"LoopClosing.min_projection_matches", kLoopClosingFixed},
      {"LoopClosing.max_drift_per_meter", kLoopClosingFixed},
      {"LoopClosing.max_correction_deg", kLoopClosingFixed},
      {"LoopClosing.max_drift_deg_per_meter", kLoopClosingFixed},
      {"LoopClosing.fusion_radius_px", kLoopClosingFixed},
      {"LoopClosing.essential_min_weight", kLoopClosingFixed},
      {"LoopClosing.pose_graph_iterations", kLoopClosingFixed},
      {"LoopClosing.pose_graph_min_correction_m", kLoopClosingFixed},
      {"LoopClosing.pose_graph_min_correction_deg", kLoopClosingFixed},
      {"LoopClosing.global_ba_iterations", kLoopClosingFixed},
      {"DynamicFilter.search_radius", kDynamicFilterFixed},
      {"DynamicFilter.max_hamming", kDynamicFilterFixed},
      {"DynamicFilter.depth_residual_scale", kDynamicFilterFixed},
      {"DynamicFilter.anchor_max_age", kDynamicFilterFixed},
      {"DynamicFilter.outside_p_init", kDynamicFilterFixed},
      {"DynamicFilter.box_depth_band", kDynamicFilterFixed},
      {"DynamicFilter.consensus_radius", kDynamicFilterFixed},
      {"DynamicFilter.consensus_depth_gap", kDynamicFilterFixed},
      {"DynamicFilter.expansion_depth_gap", kDynamicFilterFixed},
      {"OctoMap.lazy_eval", kOctoMapFixed},
      {"OctoMap.rebuild_displacement", kOctoMapFixed},
      {"OctoMap.dynamic_keypoint_radius_px", kOctoMapFixed},
  };
  return kKeys;
}

const std::vector<std::string>& KnownSettingsKeys() {
  static const std::vector<std::string> kKeys = [] {
    std::vector<std::string> keys = CameraSettingsTable().Keys();
    for (const std::string& key : IgnoredSettingsKeys()) keys.push_back(key);
    for (const std::string& key : SystemSettingsTable().Keys()) keys.push_back(key);
    for (const std::string& key : OctoMapSettingsTable().Keys()) keys.push_back(key);
    return keys;
  }();
  return kKeys;
}

std::vector<SettingDoc> SettingDocs() {
  const Settings settings = ParseSettings(kRequiredOnly, "<defaults>");
  const SystemOptions system = SystemOptionsFromSettings(settings);
  std::vector<SettingDoc> docs = CameraSettingsTable().Docs(settings);
  for (const std::string& key : IgnoredSettingsKeys()) {
    SettingDoc d;
    d.key = key;
    d.default_value = "accepted, not used";
    d.literal = false;
    d.doc = "an ORB-SLAM2 / ORB-SLAM3 key";
    docs.push_back(d);
  }
  for (const SettingDoc& d : SystemSettingsTable().Docs(system)) docs.push_back(d);
  OctoMapOptions octomap;
  ReadOptions(settings.reader, &octomap);
  for (const SettingDoc& d : OctoMapSettingsTable().Docs(octomap)) docs.push_back(d);
  return docs;
}

Settings LoadSettings(const std::string& path, const SettingsReadOptions& read_options) {
  return ReadAll(ConfigReader::FromFile(path), read_options);
}

Settings ParseSettings(const std::string& text, const std::string& name,
                       const SettingsReadOptions& read_options) {
  return ReadAll(ConfigReader::FromString(text, name), read_options);
}

}  // namespace dygslam
