#include "core/config/system_config.h"

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
  tracking.CheckOptions(options.tracking);
  const ConfigReader mapping = root.Section("LocalMapping");
  mapping.ReadIfPresent("triangulation_neighbors", &options.local_mapping.triangulation_neighbors);
  mapping.ReadIfPresent("cull_keyframes", &options.local_mapping.cull_keyframes);
  mapping.ReadIfPresent("redundancy_ratio", &options.local_mapping.redundancy_ratio);
  mapping.CheckOptions(options.local_mapping);
  return options;
}

}  // namespace dygslam
