// SE3 pose-graph optimisation with Ceres (the essential graph of loop closing): keyframe poses
// linked by relative-pose measurements, some poses held fixed. RGB-D has metric depth, so the
// graph is SE3 (no scale drift, unlike monocular Sim3).
#pragma once

#include <cstdint>
#include <map>
#include <set>
#include <vector>

#include "core/base/rigid3.h"

namespace dygslam {

struct PoseGraphEdge {
  int64_t i = -1, j = -1;
  Rigid3d i_from_j;     // measured cam_i_from_cam_j
  double weight = 1.0;  // scales the residual (information ~ weight^2)
};

struct PoseGraphSummary {
  double initial_cost = 0, final_cost = 0;
  int iterations = 0;
};

// cam_from_world: every node's pose (in/out). Edges whose nodes are missing are skipped. Fixed
// nodes keep their pose (at least one should be fixed: the gauge).
PoseGraphSummary OptimizePoseGraph(std::map<int64_t, Rigid3d>* cam_from_world,
                                   const std::vector<PoseGraphEdge>& edges,
                                   const std::set<int64_t>& fixed, int max_iterations);

}  // namespace dygslam
