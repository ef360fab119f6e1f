#include "mapping/octomap_settings.h"

namespace dygslam {

const SettingsTable<OctoMapOptions>& OctoMapSettingsTable() {
  using Row = SettingRow<OctoMapOptions>;
  static const SettingsTable<OctoMapOptions> table = {
      {
          Row("OctoMap.resolution", DYGSLAM_SETTING_FIELD(resolution),
              SettingRange::AboveAtMost(0.001, 10), "m", "leaf size"),
          Row("OctoMap.max_range", DYGSLAM_SETTING_FIELD(max_range),
              SettingRange::AboveAtMost(0, 1000), "m",
              "beams longer than this clear space up to it only, no occupied end cell"),
          Row("OctoMap.min_range", DYGSLAM_SETTING_FIELD(min_range), SettingRange::AtLeast(0), "m",
              "closer depth is no measurement"),
          Row("OctoMap.prob_hit", DYGSLAM_SETTING_FIELD(prob_hit), SettingRange::Open(0.5, 1), "",
              "sensor model: probability of an end cell"),
          Row("OctoMap.prob_miss", DYGSLAM_SETTING_FIELD(prob_miss), SettingRange::Open(0, 0.5), "",
              "sensor model: probability of a cell a beam crosses"),
          Row("OctoMap.clamping_min", DYGSLAM_SETTING_FIELD(clamping_min), SettingRange::Open(0, 1),
              "", "lower clamp of a cell's probability"),
          Row("OctoMap.clamping_max", DYGSLAM_SETTING_FIELD(clamping_max), SettingRange::Open(0, 1),
              "", "upper clamp of a cell's probability"),
          Row("OctoMap.occupancy_threshold", DYGSLAM_SETTING_FIELD(occupancy_threshold),
              SettingRange::Open(0, 1), "", "a cell above it is occupied"),
          Row("OctoMap.pixel_stride", DYGSLAM_SETTING_FIELD(pixel_stride),
              SettingRange::Closed(1, 64), "px", "every n-th pixel in u and v goes in"),
          Row("OctoMap.use_voxel_filter", DYGSLAM_SETTING_FIELD(use_voxel_filter), {}, "",
              "one point per cell of the map's resolution before insertion"),
          Row("OctoMap.use_dynamic_mask", DYGSLAM_SETTING_FIELD(use_dynamic_mask), {}, "",
              "pixels of people and dynamic features stay out (false: every valid depth pixel)"),
          Row("OctoMap.dynamic_mask_dilation_px", DYGSLAM_SETTING_FIELD(dynamic_mask_dilation_px),
              SettingRange::Closed(0, 200), "px", "the dynamic mask grows by this"),
      },
      {
          {"OctoMap.min_range", "below OctoMap.max_range",
           [](const OctoMapOptions& o) { return o.min_range < o.max_range; }},
          {"OctoMap.clamping_min", "below OctoMap.occupancy_threshold",
           [](const OctoMapOptions& o) { return o.clamping_min < o.occupancy_threshold; }},
          {"OctoMap.clamping_max", "above OctoMap.occupancy_threshold",
           [](const OctoMapOptions& o) { return o.clamping_max > o.occupancy_threshold; }},
      }};
  return table;
}

void ReadOptions(const ConfigReader& root, OctoMapOptions* options) {
  OctoMapSettingsTable().Read(root, options);
  root.CheckOptions(*options);
}

}  // namespace dygslam
