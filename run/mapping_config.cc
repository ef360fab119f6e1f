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
  s.ReadIfPresent("voxel_filter_size", &options->voxel_filter_size);
  s.ReadIfPresent("use_voxel_filter", &options->use_voxel_filter);
  s.ReadIfPresent("use_dynamic_mask", &options->use_dynamic_mask);
  s.ReadIfPresent("dynamic_mask_dilation_px", &options->dynamic_mask_dilation_px);
  s.ReadIfPresent("dynamic_keypoint_radius_px", &options->dynamic_keypoint_radius_px);
  s.ReadIfPresent("lazy_eval", &options->lazy_eval);
  s.ReadIfPresent("discretize", &options->discretize);
  s.ReadIfPresent("rebuild_displacement", &options->rebuild_displacement);
  // A misspelt key would silently keep its default: name it.
  static const char* const kKnown[] = {"resolution",
                                       "max_range",
                                       "min_range",
                                       "prob_hit",
                                       "prob_miss",
                                       "clamping_min",
                                       "clamping_max",
                                       "occupancy_threshold",
                                       "pixel_stride",
                                       "voxel_filter_size",
                                       "use_voxel_filter",
                                       "use_dynamic_mask",
                                       "dynamic_mask_dilation_px",
                                       "dynamic_keypoint_radius_px",
                                       "lazy_eval",
                                       "discretize",
                                       "rebuild_displacement"};
  for (const std::string& key : s.Keys()) {
    const std::string name = key.substr(s.prefix().size() + 1);
    bool known = false;
    std::string list;
    for (const char* k : kKnown) {
      known = known || name == k;
      list += (list.empty() ? "" : ", ") + std::string(k);
    }
    if (!known) s.Fail(name, "unknown key (known: " + list + ")");
  }
  s.CheckOptions(*options);
}

}  // namespace dygslam
