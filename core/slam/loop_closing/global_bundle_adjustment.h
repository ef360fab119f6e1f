// Global bundle adjustment, the last step of loop closing: every keyframe and every map point
// seen twice, in one Ceres problem (Schur complement, the first keyframe fixed), written back
// only if the map was not corrected meanwhile; keyframes made since follow their parent chain and
// points not in the problem their reference keyframe.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <vector>

#include "core/slam/map/map.h"
#include "core/slam/optimize/optimizer.h"

namespace dygslam {

struct GlobalBundleAdjustmentResult {
  enum class Outcome {
    kNotRun,     // the map was corrected before it started, or has nothing to adjust
    kDiscarded,  // aborted, failed, or the map was corrected while it ran: nothing written
    kWritten,
  };
  Outcome outcome = Outcome::kNotRun;
  size_t keyframes = 0, points = 0, observations = 0;
  std::vector<int64_t> moved;  // keyframes whose pose changed
};

// Runs on the map state of correction epoch `epoch`. `on_solve` is called (with the time the
// run started) when the solve begins; `abort` stops the solver between iterations. Takes the map
// lock to read the problem and to write it back, not while solving.
GlobalBundleAdjustmentResult RunGlobalBundleAdjustment(
    Map& map, int64_t epoch, const OptimizerOptions& optimizer, int iterations,
    const std::atomic<bool>& abort,
    const std::function<void(std::chrono::steady_clock::time_point)>& on_solve);

}  // namespace dygslam
