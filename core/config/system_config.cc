#include "core/config/system_config.h"

#include "core/base/error.h"

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
  tracking.ReadIfPresent("max_frames_between_keyframes", &options.tracking.max_frames_between_keyframes);
  tracking.ReadIfPresent("ref_ratio", &options.tracking.ref_ratio);
  tracking.ReadIfPresent("dense_fallback", &options.tracking.dense_fallback);
  tracking.ReadIfPresent("fallback_min_inlier_fraction",
                         &options.tracking.fallback.min_inlier_fraction);
  tracking.ReadIfPresent("fallback_min_inliers", &options.tracking.fallback.min_inliers);
  tracking.ReadIfPresent("fallback_check_below_inliers",
                         &options.tracking.fallback_check_below_inliers);
  tracking.ReadIfPresent("fallback_override_fraction_gain",
                         &options.tracking.fallback_override_fraction_gain);
  tracking.CheckOptions(options.tracking);
  const ConfigReader mapping = root.Section("LocalMapping");
  mapping.ReadIfPresent("triangulation_neighbors", &options.local_mapping.triangulation_neighbors);
  mapping.ReadIfPresent("cull_keyframes", &options.local_mapping.cull_keyframes);
  mapping.ReadIfPresent("redundancy_ratio", &options.local_mapping.redundancy_ratio);
  mapping.CheckOptions(options.local_mapping);

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
  } else {
    try {
      options.detector = DetectorOptionsForModel(model);
    } catch (const InputError& e) {
      // Resolved lazily: a run without detection (filter none/geometry) needs no model.
      options.detector = DetectorOptions();
    }
  }
  detector.ReadIfPresent("input_width", &options.detector.input_width);
  detector.ReadIfPresent("input_height", &options.detector.input_height);
  detector.ReadIfPresent("confidence_threshold", &options.detector.confidence_threshold);
  detector.ReadIfPresent("nms_threshold", &options.detector.nms_threshold);
  detector.ReadIfPresent("num_threads", &options.detector.num_threads);
  std::vector<std::string> classes;
  if (detector.ReadIfPresent("dynamic_classes", &classes)) options.detector.dynamic_classes = classes;
  return options;
}

}  // namespace dygslam
