#include "core/config/settings.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>

namespace dygslam {
namespace {

// "1e+308" style: short, exact enough for a message.
std::string Short(double v) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g", v);
  return text;
}

// Values that pass the types and signs but cannot describe a real RGB-D camera (a focal length of
// 1e308 px, a principal point outside the image, k1 = 1e10): tracking would "succeed" on nonsense.
void CheckPlausibleCamera(const ConfigReader& camera, const PinholeCamera& c) {
  const double side = std::max(c.width, c.height);
  const double min_focal = 0.05 * side, max_focal = 100.0 * side;
  for (const auto& [key, value] : {std::pair<const char*, double>{"fx", c.fx}, {"fy", c.fy}}) {
    if (value < min_focal || value > max_focal) {
      camera.Fail(key, "focal length " + Short(value) + " px is implausible for a " +
                           std::to_string(c.width) + "x" + std::to_string(c.height) +
                           " image (expected " + Short(min_focal) + " to " + Short(max_focal) +
                           " px)");
    }
  }
  if (c.cx < 0 || c.cx > c.width) {
    camera.Fail("cx", "principal point " + Short(c.cx) + " px is outside the image (0 to " +
                          std::to_string(c.width) + ", Camera.width)");
  }
  if (c.cy < 0 || c.cy > c.height) {
    camera.Fail("cy", "principal point " + Short(c.cy) + " px is outside the image (0 to " +
                          std::to_string(c.height) + ", Camera.height)");
  }
  for (const auto& [key, value] :
       {std::pair<const char*, double>{"k1", c.k1}, {"k2", c.k2}, {"k3", c.k3}}) {
    if (std::abs(value) > 10.0) {
      camera.Fail(key, "radial distortion " + Short(value) +
                           " is implausible (expected |value| <= 10; real lenses are below 2)");
    }
  }
  for (const auto& [key, value] : {std::pair<const char*, double>{"p1", c.p1}, {"p2", c.p2}}) {
    if (std::abs(value) > 1.0) {
      camera.Fail(
          key, "tangential distortion " + Short(value) + " is implausible (expected |value| <= 1)");
    }
  }
}

// Camera.bf is ORB-SLAM2's stereo baseline times fx (the RGB-D "virtual right camera"): bf / fx is
// a baseline in metres, a few centimetres for a Kinect-class sensor (TUM / Bonn: 40 / 535 =
// 0.075 m). Zero or negative has no meaning; above 1 m no RGB-D sensor exists, and the close/far
// depth threshold ThDepth * bf / fx would put every point "close".
void CheckPlausibleBaseline(const ConfigReader& camera, const PinholeCamera& c,
                            const RgbdSensorOptions& sensor) {
  constexpr double kMaxBaselineM = 1.0;
  const double baseline = sensor.bf / c.fx;
  const std::string what = "Camera.bf is the stereo baseline times Camera.fx (" + Short(sensor.bf) +
                           " / " + Short(c.fx) + " px = " + Short(baseline) + " m)";
  if (!(sensor.bf > 0)) {
    camera.Fail("bf", "must be > 0: " + what + "; RGB-D sensors have a few centimetres (e.g. " +
                          Short(0.075 * c.fx) + " for 0.075 m)");
  }
  if (!(baseline <= kMaxBaselineM)) {
    camera.Fail("bf", "implausible baseline: " + what + ", expected at most " +
                          Short(kMaxBaselineM) + " m (e.g. " + Short(0.075 * c.fx) +
                          " for 0.075 m; is it given in mm or without the factor fx?)");
  }
}

Settings ReadSettings(ConfigReader reader, const SettingsReadOptions& read_options) {
  Settings s;
  s.path = reader.path();
  for (const ConfigReader::UnknownKey& u : reader.UnknownKeys(KnownSettingsKeys())) {
    std::string message = reader.UnknownKeyMessage(u);
    for (const auto& [key, reason] : RetiredSettingsKeys()) {
      if (u.key == key) {
        message = InputError::Format(
            reader.path(), u.line,
            "key '" + key + "' is no longer a setting (" + reason + "): remove it");
      }
    }
    if (read_options.unknown_keys == UnknownKeyPolicy::kError) {
      throw InputError(message + " [unknown settings keys are errors here]");
    }
    s.warnings.push_back(message);
    if (read_options.print_warnings) std::fprintf(stderr, "warning: %s\n", message.c_str());
  }
  const ConfigReader camera = reader.Section("Camera");
  s.camera.fx = camera.Require<double>("fx");
  s.camera.fy = camera.Require<double>("fy");
  s.camera.cx = camera.Require<double>("cx");
  s.camera.cy = camera.Require<double>("cy");
  s.camera.k1 = camera.Require<double>("k1");
  s.camera.k2 = camera.Require<double>("k2");
  s.camera.p1 = camera.Require<double>("p1");
  s.camera.p2 = camera.Require<double>("p2");
  camera.ReadIfPresent("k3", &s.camera.k3);
  camera.ReadIfPresent("width", &s.camera.width);
  camera.ReadIfPresent("height", &s.camera.height);
  camera.ReadIfPresent("fps", &s.sensor.fps);
  camera.ReadIfPresent("bf", &s.sensor.bf);
  reader.ReadIfPresent("ThDepth", &s.sensor.th_depth);
  reader.ReadIfPresent("DepthMapFactor", &s.sensor.depth_map_factor);
  const ConfigReader orb = reader.Section("ORBextractor");
  orb.ReadIfPresent("nFeatures", &s.orb.num_features);
  orb.ReadIfPresent("scaleFactor", &s.orb.scale_factor);
  orb.ReadIfPresent("nLevels", &s.orb.num_levels);
  orb.ReadIfPresent("iniThFAST", &s.orb.ini_th_fast);
  orb.ReadIfPresent("minThFAST", &s.orb.min_th_fast);
  reader.CheckOptions(s.camera);
  CheckPlausibleCamera(camera, s.camera);
  if (camera.Has("bf")) CheckPlausibleBaseline(camera, s.camera, s.sensor);
  reader.CheckOptions(s.sensor);
  // Finite and positive but absurd: a frame rate that makes the derived keyframe interval
  // (Tracking.max_frames_between_keyframes = fps) overflow, a close-depth threshold beyond any
  // sensor. Named by their own keys and lines, not by what they break later.
  constexpr double kMaxFps = 1000.0, kMaxThDepth = 1000.0;
  if (s.sensor.fps > kMaxFps) {
    camera.Fail("fps", "implausible frame rate " + Short(s.sensor.fps) + " (expected at most " +
                           Short(kMaxFps) + "; RGB-D sensors run at 5 to 90 Hz)");
  }
  if (s.sensor.th_depth > kMaxThDepth) {
    reader.Fail("ThDepth", "implausible close-depth factor " + Short(s.sensor.th_depth) +
                               " (close points are nearer than ThDepth x Camera.bf / Camera.fx = " +
                               Short(s.sensor.close_depth(s.camera.fx)) + " m; expected at most " +
                               Short(kMaxThDepth) + ", TUM / Bonn use 40: " +
                               Short(40.0 * s.sensor.bf / s.camera.fx) + " m)");
  }
  // Depth image units per metre: 1 for float images in metres, 1000 for millimetres, 5000 for
  // TUM / Bonn. Below 1 a unit would be longer than a metre (a 16-bit image would reach beyond
  // 65 km): every point lands kilometres away and nothing downstream can tell.
  constexpr double kMinDepthMapFactor = 1, kMaxDepthMapFactor = 1e5;
  if (s.sensor.depth_map_factor < kMinDepthMapFactor ||
      s.sensor.depth_map_factor > kMaxDepthMapFactor) {
    reader.Fail("DepthMapFactor", "implausible depth scale " + Short(s.sensor.depth_map_factor) +
                                      " (depth image units per metre; expected " +
                                      Short(kMinDepthMapFactor) + " to " +
                                      Short(kMaxDepthMapFactor) +
                                      ": 1 for float depth in metres, 1000 for millimetres, "
                                      "TUM / Bonn use 5000: 0.2 mm per unit)");
  }
  reader.CheckOptions(s.orb);
  s.reader = std::move(reader);
  return s;
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
  static const std::vector<std::string> kKeys = {
      // ORB-SLAM2 (RGB-D): read.
      "Camera.fx", "Camera.fy", "Camera.cx", "Camera.cy", "Camera.k1", "Camera.k2", "Camera.p1",
      "Camera.p2", "Camera.k3", "Camera.width", "Camera.height", "Camera.fps", "Camera.bf",
      "ThDepth", "DepthMapFactor", "ORBextractor.nFeatures", "ORBextractor.scaleFactor",
      "ORBextractor.nLevels", "ORBextractor.iniThFAST", "ORBextractor.minThFAST",
      // ORB-SLAM2 / ORB-SLAM3 keys accepted and not used.
      "Camera.RGB", "Camera.type", "File.version", "Viewer.*",
      // run/system_config.cc.
      "Tracking.init_min_features", "Tracking.max_frames_between_keyframes",
      "Tracking.fallback_smoothing", "Tracking.dense_fallback", "DynamicFilter.world_anchors",
      "LocalMapping.cull_keyframes", "DynamicFilter.mode", "DynamicFilter.C1",
      "DynamicFilter.alpha", "DynamicFilter.Q", "DynamicFilter.R", "DynamicFilter.P_init",
      "DynamicFilter.C2", "DynamicFilter.delta", "DynamicFilter.threshold",
      "DynamicFilter.box_margin", "DynamicFilter.box_margin_fraction",
      "DynamicFilter.fundamental_threshold", "DynamicFilter.depth_residual",
      "DynamicFilter.expand_outside", "Detector.model", "Detector.cfg", "Detector.weights",
      "Detector.names", "Detector.input_width", "Detector.input_height",
      "Detector.confidence_threshold", "Detector.nms_threshold", "Detector.num_threads",
      "Detector.every_n_frames", "Detector.shift_carried_boxes", "Detector.dynamic_classes",
      "LoopClosing.vocabulary", "LoopClosing.enabled", "LoopClosing.revisit_min_path_m",
      "LoopClosing.max_correction_m", "LoopClosing.global_bundle_adjustment",
      // run/mapping_config.cc.
      "OctoMap.resolution", "OctoMap.max_range", "OctoMap.min_range", "OctoMap.prob_hit",
      "OctoMap.prob_miss", "OctoMap.clamping_min", "OctoMap.clamping_max",
      "OctoMap.occupancy_threshold", "OctoMap.pixel_stride", "OctoMap.use_voxel_filter",
      "OctoMap.use_dynamic_mask", "OctoMap.dynamic_mask_dilation_px"};
  return kKeys;
}

Settings LoadSettings(const std::string& path, const SettingsReadOptions& read_options) {
  return ReadSettings(ConfigReader::FromFile(path), read_options);
}

Settings ParseSettings(const std::string& text, const std::string& name,
                       const SettingsReadOptions& read_options) {
  return ReadSettings(ConfigReader::FromString(text, name), read_options);
}

std::string DefaultSettingsPath(const std::string& dataset_dir, const std::string& config_dir) {
  namespace fs = std::filesystem;
  const fs::path own = fs::path(dataset_dir) / "camera.yaml";
  std::error_code ec;
  if (fs::is_regular_file(own, ec)) return own.string();
  const std::string name = fs::path(dataset_dir).lexically_normal().filename().string();
  std::string preset = "bonn.yaml";
  if (name.find("freiburg1") != std::string::npos) preset = "tum1.yaml";
  if (name.find("freiburg2") != std::string::npos) preset = "tum2.yaml";
  if (name.find("freiburg3") != std::string::npos) preset = "tum3.yaml";
  return (fs::path(config_dir) / preset).string();
}

}  // namespace dygslam
