// The benchmark's configurations: the five of `--filter` (none, boxes, geometry, paper, full) and
// the ablation steps from the paper's method to ours, one extension at a time
// (docs/how_it_works.md, "Dynamic filter"):
//   paper+margin           paper + boxes grown by 10 % of their width on each side
//   paper+margin+demotion  + features kept inside boxes never seed map points and do not count
//                          toward the local-map inlier minimum
// (full then adds the re-extraction outside the boxes on crowded frames and the depth residual.)
#pragma once

#include <string>
#include <vector>

#include "core/system/system.h"

namespace dygslam {

// Every configuration a bench accepts, in report order.
const std::vector<std::string>& BenchConfigurationNames();

// The `--filter` configuration `name` starts from: itself, or "paper" for an ablation step.
// Throws InvalidOptions naming the accepted names.
std::string BaseFilterConfiguration(const std::string& name);

// What an ablation step adds on top of its base (nothing for the five of `--filter`).
void ApplyAblationStep(const std::string& name, SystemOptions* options);

}  // namespace dygslam
