#include "run/mapping_config.h"

#include <string>

namespace dygslam {

void ReadOptions(const ConfigReader& root, OctoMapOptions* options) {
  const ConfigReader s = root.Section("OctoMap");
  s.ReadIfPresent("resolution", &options->resolution);
  s.ReadIfPresent("max_range", &options->max_range);
  s.ReadIfPresent("min_range", &options->min_range);
  s.ReadIfPresent("prob_hit", &options->prob_hit);
  s.ReadIfPresent("prob_miss", &options->prob_miss);
  s.ReadIfPresent("clamping_min", &options->clamping_min);
  s.ReadIfPresent("clamping_max", &options->clamping_max);
  s.ReadIfPresent("occupancy_threshold", &options->occupancy_threshold);
  s.ReadIfPresent("pixel_stride", &options->pixel_stride);
  s.ReadIfPresent("use_voxel_filter", &options->use_voxel_filter);
  s.ReadIfPresent("use_dynamic_mask", &options->use_dynamic_mask);
  s.ReadIfPresent("dynamic_mask_dilation_px", &options->dynamic_mask_dilation_px);
  // A misspelt key is reported where every other section's is: LoadSettings warns about it with
  // its line and the closest known key (an error with --strict-settings), KnownSettingsKeys().
  s.CheckOptions(*options);
}

}  // namespace dygslam
