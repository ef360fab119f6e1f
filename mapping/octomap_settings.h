// OctoMapOptions from the settings file's optional `OctoMap:` section (defaults in
// mapping/octomap_builder.h; keys, ranges and docs in OctoMapSettingsTable). Keys are the option
// names:
//
//   OctoMap:
//     resolution: 0.05          # leaf size (m)
//     max_range: 4.0            # beams longer than this clear space up to max_range only (m)
//     min_range: 0.3            # closer depth is no measurement (m)
//     prob_hit: 0.7             # OctoMap sensor model
//     prob_miss: 0.4
//     clamping_min: 0.12
//     clamping_max: 0.97
//     occupancy_threshold: 0.5
//     pixel_stride: 2           # every n-th pixel in u and v
//     use_voxel_filter: true    # one point per cell of the map's resolution before insertion
//     use_dynamic_mask: true    # false: every valid depth pixel goes in (no filter)
//     dynamic_mask_dilation_px: 5
//
// Flat keys ("OctoMap.resolution: 0.05") work too. Bad values: InputError "<file>:<line>: key
// 'OctoMap.<name>': ...".
#pragma once

#include "core/config/config_reader.h"
#include "core/config/setting_table.h"
#include "mapping/octomap_builder.h"

namespace dygslam {

const SettingsTable<OctoMapOptions>& OctoMapSettingsTable();

// Overwrites the fields of *options whose keys are present; checks the result.
void ReadOptions(const ConfigReader& root, OctoMapOptions* options);

}  // namespace dygslam
