#include "run/system_config.h"

#include <cstdlib>
#include <filesystem>

#include "core/base/error.h"

#ifndef DYGSLAM_DEFAULT_VOCABULARY
#define DYGSLAM_DEFAULT_VOCABULARY ""
#endif

namespace dygslam {

SystemOptions SystemOptionsFromSettings(const Settings& settings) {
  SystemOptions options;
  options.camera = settings.camera;
  options.sensor = settings.sensor;
  options.orb = settings.orb;
  const ConfigReader& root = settings.reader;
  // Keyframe spacing follows the frame rate unless set.
  options.tracking.max_frames_between_keyframes = static_cast<int>(settings.sensor.fps);
  const ConfigReader tracking = root.Section("Tracking");
  tracking.ReadIfPresent("init_min_features", &options.tracking.init_min_features);
  tracking.ReadIfPresent("motion_radius_px", &options.tracking.motion_radius_px);
  tracking.ReadIfPresent("max_frames_between_keyframes",
                         &options.tracking.max_frames_between_keyframes);
  tracking.ReadIfPresent("ref_ratio", &options.tracking.ref_ratio);
  tracking.ReadIfPresent("dense_fallback", &options.tracking.dense_fallback);
  tracking.ReadIfPresent("fallback_min_inlier_fraction",
                         &options.tracking.fallback.min_inlier_fraction);
  tracking.ReadIfPresent("fallback_min_inliers", &options.tracking.fallback.min_inliers);
  tracking.ReadIfPresent("fallback_check_below_inliers",
                         &options.tracking.fallback_check_below_inliers);
  tracking.ReadIfPresent("fallback_override_fraction_gain",
                         &options.tracking.fallback_override_fraction_gain);
  tracking.ReadIfPresent("fallback_smoothing", &options.tracking.fallback_smoothing);
  tracking.ReadIfPresent("fallback_smoothing_weak_inliers",
                         &options.tracking.fallback_smoothing_weak_inliers);
  tracking.CheckOptions(options.tracking);
  const ConfigReader mapping = root.Section("LocalMapping");
  mapping.ReadIfPresent("triangulation_neighbors", &options.local_mapping.triangulation_neighbors);
  mapping.ReadIfPresent("cull_keyframes", &options.local_mapping.cull_keyframes);
  mapping.ReadIfPresent("redundancy_ratio", &options.local_mapping.redundancy_ratio);
  mapping.CheckOptions(options.local_mapping);

  // LoopClosing: place recognition and loop closing. vocabulary: a path relative to the settings
  // file, "none" (no place recognition: brute-force relocalization, no loops), or absent:
  // $DYGSLAM_VOCABULARY, else vocabulary.dygvoc beside the settings file, else the shipped
  // config/vocabulary.dygvoc of the source tree. A missing file fails when the system starts.
  const ConfigReader loops = root.Section("LoopClosing");
  LoopClosingOptions& lc = options.loop_closing;
  std::string vocabulary;
  if (loops.ReadIfPresent("vocabulary", &vocabulary)) {
    if (vocabulary == "none") {
      lc.vocabulary.clear();
    } else {
      std::filesystem::path path(vocabulary);
      if (path.is_relative() && !settings.path.empty())
        path = std::filesystem::path(settings.path).parent_path() / path;
      lc.vocabulary = path.lexically_normal().string();
      if (!std::filesystem::exists(lc.vocabulary))
        loops.Fail("vocabulary", "file not found: " + lc.vocabulary);
    }
  } else if (const char* env = std::getenv("DYGSLAM_VOCABULARY"); env != nullptr && *env != '\0') {
    lc.vocabulary = env;
  } else {
    // Beside the settings file (the presets in config/, also where the Docker image installs
    // them), else the source tree's (generated sequences carry their own camera.yaml).
    const std::filesystem::path beside =
        settings.path.empty()
            ? std::filesystem::path()
            : std::filesystem::path(settings.path).parent_path() / "vocabulary.dygvoc";
    lc.vocabulary = !beside.empty() && std::filesystem::exists(beside)
                        ? beside.string()
                        : std::string(DYGSLAM_DEFAULT_VOCABULARY);
  }
  loops.ReadIfPresent("enabled", &lc.enabled);
  loops.ReadIfPresent("min_keyframe_gap", &lc.min_keyframe_gap);
  loops.ReadIfPresent("revisit_min_path_m", &lc.revisit_min_path_m);
  loops.ReadIfPresent("consistency", &lc.consistency);
  loops.ReadIfPresent("min_bow_matches", &lc.min_bow_matches);
  loops.ReadIfPresent("ransac_iterations", &lc.ransac_iterations);
  loops.ReadIfPresent("ransac_threshold_px", &lc.ransac_threshold_px);
  loops.ReadIfPresent("min_ransac_inliers", &lc.min_ransac_inliers);
  loops.ReadIfPresent("min_inlier_ratio", &lc.min_inlier_ratio);
  loops.ReadIfPresent("min_projection_matches", &lc.min_projection_matches);
  loops.ReadIfPresent("max_correction_m", &lc.max_correction_m);
  loops.ReadIfPresent("max_drift_per_meter", &lc.max_drift_per_meter);
  loops.ReadIfPresent("max_correction_deg", &lc.max_correction_deg);
  loops.ReadIfPresent("max_drift_deg_per_meter", &lc.max_drift_deg_per_meter);
  loops.ReadIfPresent("fusion_radius_px", &lc.fusion_radius_px);
  loops.ReadIfPresent("essential_min_weight", &lc.essential_min_weight);
  loops.ReadIfPresent("pose_graph_iterations", &lc.pose_graph_iterations);
  loops.ReadIfPresent("global_bundle_adjustment", &lc.global_bundle_adjustment);
  loops.ReadIfPresent("global_ba_iterations", &lc.global_ba_iterations);
  loops.CheckOptions(lc);

  // DynamicFilter: the paper's parameters (defaults in DynamicFilterOptions).
  const ConfigReader filter = root.Section("DynamicFilter");
  std::string mode;
  if (filter.ReadIfPresent("mode", &mode)) {
    try {
      options.filter_mode = ParseFilterMode(mode);
    } catch (const InvalidOptions& e) {
      filter.Fail("mode", e.what());
    }
  }
  DynamicFilterOptions& f = options.filter;
  filter.ReadIfPresent("C1", &f.c1);
  filter.ReadIfPresent("alpha", &f.alpha);
  filter.ReadIfPresent("Q", &f.q);
  filter.ReadIfPresent("R", &f.r);
  filter.ReadIfPresent("P_init", &f.p_init);
  filter.ReadIfPresent("C2", &f.c2);
  filter.ReadIfPresent("delta", &f.delta);
  filter.ReadIfPresent("threshold", &f.threshold);
  filter.ReadIfPresent("box_margin", &f.box_margin);
  filter.ReadIfPresent("box_margin_fraction", &f.box_margin_fraction);
  filter.ReadIfPresent("search_radius", &f.search_radius);
  filter.ReadIfPresent("max_hamming", &f.max_hamming);
  filter.ReadIfPresent("fundamental_threshold", &f.fundamental_threshold);
  filter.CheckOptions(f);

  // Detector: a shipped model by name, or explicit Darknet files.
  const ConfigReader detector = root.Section("Detector");
  std::string model = "yolo-fastest-1.1";
  detector.ReadIfPresent("model", &model);
  if (detector.Has("cfg")) {
    options.detector.cfg_path = detector.Require<std::string>("cfg");
    options.detector.weights_path = detector.Require<std::string>("weights");
    options.detector.names_path = detector.Require<std::string>("names");
  } else if (detector.Has("model")) {
    // A model named in the file must exist: falling back to another one would also drop the
    // input size, thresholds and classes given with it.
    try {
      options.detector = DetectorOptionsForModel(model);
    } catch (const InputError& e) {
      detector.Fail("model", e.what());
    }
  } else {
    try {
      options.detector = DetectorOptionsForModel(model);
    } catch (const InputError&) {
      // The default model, resolved lazily: a run without detection (filter none/geometry)
      // needs no model files.
      options.detector = DetectorOptions();
    }
  }
  detector.ReadIfPresent("input_width", &options.detector.input_width);
  detector.ReadIfPresent("input_height", &options.detector.input_height);
  detector.ReadIfPresent("confidence_threshold", &options.detector.confidence_threshold);
  detector.ReadIfPresent("nms_threshold", &options.detector.nms_threshold);
  detector.ReadIfPresent("num_threads", &options.detector.num_threads);
  std::vector<std::string> classes;
  if (detector.ReadIfPresent("dynamic_classes", &classes))
    options.detector.dynamic_classes = classes;
  // The values of the file, checked here so that a bad one names its line (model files that are
  // resolved later stand in as placeholders).
  DetectorOptions check = options.detector;
  if (check.cfg_path.empty()) check.cfg_path = check.weights_path = check.names_path = "default";
  detector.CheckOptions(check);
  return options;
}

}  // namespace dygslam
