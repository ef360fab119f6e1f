// Pose-only optimisation (a dedicated 6-dof solver) and local bundle adjustment with Ceres (robust Huber kernel,
// outlier-rejection rounds with chi-square thresholds as in ORB-SLAM2's RGB-D mode).
#pragma once

#include <atomic>
#include <memory>

#include "core/slam/frame.h"
#include "core/slam/map.h"

namespace dygslam {

struct OptimizerOptions {
  int pose_rounds = 4;
  int pose_iterations = 10;
  double chi2_mono = 5.991;    // 95 % with 2 dof
  double chi2_stereo = 7.815;  // 95 % with 3 dof
  int ba_iterations_first = 5;
  int ba_iterations_second = 10;
  void Check() const {
    DYGSLAM_CHECK_OPTION(pose_rounds >= 1, "Optimizer.pose_rounds");
    DYGSLAM_CHECK_OPTION(pose_iterations >= 1, "Optimizer.pose_iterations");
  }
};

// Optimises frame.cam_from_world against its matched map points (frame.map_points); sets
// frame.outlier. Map point positions are read by the caller's thread: hold the map lock.
// Returns the number of inliers. ORB-SLAM2's scheme: pose_rounds rounds of <= pose_iterations
// Levenberg-Marquardt iterations (core/slam/pose_solver.h), Huber kernel in all but the last,
// every observation re-classified by its chi2 after each round.
int OptimizePose(Frame& frame, const OptimizerOptions& options);

// The same rounds with a new Ceres problem per round (the earlier implementation): the
// reference the dedicated solver is tested against; not used by the system.
int OptimizePoseWithCeres(Frame& frame, const OptimizerOptions& options);

// Local BA around `kf`: it and its covisible keyframes are optimised with every point they see;
// other keyframes seeing those points are fixed. Takes the map lock only to copy the problem in
// and to write the result back. `abort` may be set by tracking to stop early.
void LocalBundleAdjustment(Map& map, const std::shared_ptr<KeyFrame>& kf, const OptimizerOptions& options,
                           const std::atomic<bool>* abort, bool deterministic);

// Bundle adjustment of every keyframe and point of the map (the first keyframe fixed), the same
// two rounds as the local one (robust, then without the outliers); outlier observations are
// dropped. Takes the map lock to copy the problem in and to write the result back.
void GlobalBundleAdjustment(Map& map, const OptimizerOptions& options, int iterations_first,
                            int iterations_second);

}  // namespace dygslam
