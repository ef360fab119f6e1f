// Pose-only optimisation (a dedicated 6-dof solver) and local bundle adjustment with Ceres (robust
// Huber kernel, outlier-rejection rounds with chi-square thresholds as in ORB-SLAM2's RGB-D mode).
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <set>
#include <vector>

#include "core/slam/map/frame.h"
#include "core/slam/map/map.h"
#include "core/slam/optimize/projection_model.h"

namespace dygslam {

struct OptimizerOptions {
  int pose_rounds = 4;
  int pose_iterations = 10;
  double chi2_mono = 5.991;    // 95 % with 2 dof
  double chi2_stereo = 7.815;  // 95 % with 3 dof
  int ba_iterations_first = 5;
  int ba_iterations_second = 10;
  // Local BA: a prior on each keyframe pose it moves, at the pose it had, in the directions its
  // points leave nearly free (BundleSolverOptions::prior_sigma_*: where their information is below
  // that of these standard deviations); settings key LocalMapping.pose_prior. When a person covers
  // most of the view the static points left lie in a narrow strip at one depth, where yaw and
  // sideways translation explain the same image motion; without the prior one solve slid such a
  // keyframe 18 cm along that direction and the frames after it followed. Directions the points
  // fix get no prior, so ordinary corrections are not held back. Loop correction and global BA
  // have no prior. Measured with and without on the benchmark sequences (BENCHMARKS.md).
  bool local_ba_pose_prior = true;
  double local_ba_prior_sigma_translation = 0.01;  // metres
  double local_ba_prior_sigma_rotation_deg = 0.2;  // degrees
  // Pose-only optimisation: a prior at the motion model's prediction (Frame::motion_prior), in
  // the directions the frame's matches leave nearly free (information below the prior's), as the
  // local BA's prior above. Where the static features left lie in a strip beside a person filling
  // the view, yaw and sideways translation explain the same image motion and the matches alone
  // let the pose slide along that direction. The standard deviations are a loose bound of one
  // frame of motion-model error for a hand-held camera at 30 Hz: a tighter prior (3 mm, 1 deg,
  // the dense fallback's) acted on ordinary frames too and made bonn_crowd_part worse. Tracking
  // gives no prediction after a dense fallback frame (its motion is no reliable prediction: one
  // pulled a returning frame 7 cm off). Measured with and without on the benchmark sequences
  // (BENCHMARKS.md).
  bool pose_motion_prior = true;
  double pose_prior_sigma_translation = 0.01;  // metres
  double pose_prior_sigma_rotation_deg = 3.0;  // degrees
  void Check() const {
    DYGSLAM_CHECK_OPTION(pose_rounds >= 1, "Optimizer.pose_rounds");
    DYGSLAM_CHECK_OPTION(pose_iterations >= 1, "Optimizer.pose_iterations");
    DYGSLAM_CHECK_OPTION(local_ba_prior_sigma_translation >= 0,
                         "Optimizer.local_ba_prior_sigma_translation");
    DYGSLAM_CHECK_OPTION(local_ba_prior_sigma_rotation_deg >= 0,
                         "Optimizer.local_ba_prior_sigma_rotation_deg");
    DYGSLAM_CHECK_OPTION(pose_prior_sigma_translation > 0,
                         "Optimizer.pose_prior_sigma_translation");
    DYGSLAM_CHECK_OPTION(pose_prior_sigma_rotation_deg > 0,
                         "Optimizer.pose_prior_sigma_rotation_deg");
  }
};

// Optimises frame.cam_from_world against its matched map points (frame.map_points); sets
// frame.outlier. Map point positions are read by the caller's thread: hold the map lock.
// Returns the number of inliers. ORB-SLAM2's scheme: pose_rounds rounds of <= pose_iterations
// Levenberg-Marquardt iterations (core/slam/optimize/pose_solver.h), Huber kernel in all but the
// last, every observation re-classified by its chi2 after each round.
int OptimizePose(Frame& frame, const OptimizerOptions& options);

// A bundle adjustment in three steps, so that the solve can run on another thread while the map
// goes on being used: PrepareBundle copies the problem in (under the map lock), SolveBundle works
// on the copy only (no lock, no map access), ApplyBundle writes the result back (under the map
// lock). The result does not depend on which thread solves or when.
struct BundleObservation {
  int64_t kf_id;
  int64_t point_id;
  Eigen::Vector3d measurement;  // u, v, u_right (0 when mono)
  double sqrt_info;
  bool stereo;
};
struct BundleProblem {
  std::map<int64_t, std::array<double, 7>> poses;  // optimised and fixed keyframes
  std::set<int64_t> fixed;
  std::map<int64_t, Eigen::Vector3d> points;
  std::vector<BundleObservation> observations;
  std::vector<uint8_t> outlier;  // per observation, after SolveBundle
  ProjectionModel model;
  int64_t epoch = 0;          // the map's correction epoch when copied in
  bool local_window = false;  // PrepareLocalBundle: the local BA's pose prior applies
  bool solved = false;
  bool empty() const { return observations.empty(); }
};
// The keyframes `local` with every point they see; other keyframes observing those points are
// fixed, and so is the gauge. Hold the map lock.
BundleProblem PrepareBundle(const Map& map, const std::vector<std::shared_ptr<KeyFrame>>& local);
// The local window of `kf`: it and its covisible keyframes. Hold the map lock.
BundleProblem PrepareLocalBundle(const Map& map, const std::shared_ptr<KeyFrame>& kf);
// Two rounds (robust, then without the outliers), as ORB-SLAM2's RGB-D local BA, with the pose
// prior of OptimizerOptions on a local window. `abort` (may be null) stops the solve early.
void SolveBundle(BundleProblem& problem, const OptimizerOptions& options, int iterations_first,
                 int iterations_second, const std::atomic<bool>* abort = nullptr);
// Drops outlier observations and writes poses and points back; false (nothing written) when the
// problem is empty or a loop correction moved the map since it was copied. Hold the map lock.
bool ApplyBundle(Map& map, const BundleProblem& problem);

// Local BA around `kf` in one call (prepare, solve, apply; the map lock only to copy in and
// write back). `abort` may be set by another thread to stop early.
void LocalBundleAdjustment(Map& map, const std::shared_ptr<KeyFrame>& kf,
                           const OptimizerOptions& options,
                           const std::atomic<bool>* abort = nullptr);

// Bundle adjustment of every keyframe and point of the map (the first keyframe fixed), the same
// two rounds as the local one (robust, then without the outliers); outlier observations are
// dropped. Takes the map lock to copy the problem in and to write the result back.
void GlobalBundleAdjustment(Map& map, const OptimizerOptions& options, int iterations_first,
                            int iterations_second);

}  // namespace dygslam
