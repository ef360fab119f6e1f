// Trajectory accuracy with the conventions of the TUM RGB-D benchmark tools.
//
// ATE (evaluate_ate.py): estimate and ground truth are associated by timestamp (greedy nearest
// one-to-one, |t_gt - (t_est + offset)| < max_time_difference), the estimate positions are aligned
// onto the ground-truth positions with the closed-form rigid (Horn / Umeyama without scale)
// alignment, and the per-pair translational error is ||gt - (R * est + t)||.
//
// RPE (evaluate_rpe.py --fixed_delta --delta 1 --delta_unit s): for every estimate pose i, j is the
// estimate pose closest to t_i + delta (pairs whose j is the last estimate pose are skipped, as in
// the reference script); both ends are matched to the closest ground-truth pose (skipped when
// farther than twice the median ground-truth interval); the error is
// (est_j^-1 est_i)^-1 (gt_j^-1 gt_i) = (est_i^-1 est_j)(gt_i^-1 gt_j)^-1, reported as translation
// norm and rotation angle per delta. All pairs are used (no random sub-sampling).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/base/rigid3.h"
#include "core/base/types.h"

namespace dygslam {

struct ErrorStatistics {
  double rmse = 0, mean = 0, median = 0, sd = 0, min = 0, max = 0;  // sd: population
};
// Throws std::invalid_argument for an empty input.
ErrorStatistics ComputeErrorStatistics(const std::vector<double>& errors);

struct AteOptions {
  double max_time_difference = 0.02;  // seconds
  double offset = 0.0;                // seconds added to estimate stamps
  void Check() const;
};

struct AteResult {
  size_t num_pairs = 0;
  ErrorStatistics error;  // metres
  // Alignment applied to the estimate: aligned = gt_from_est * est.
  Rigid3d gt_from_est;
  // Per associated pair, in time order.
  std::vector<Timestamp> gt_stamps;
  std::vector<Timestamp> est_stamps;
  std::vector<Eigen::Vector3d> gt_positions;
  std::vector<Eigen::Vector3d> aligned_positions;
  std::vector<double> errors;
  // The whole estimate (all poses, not only associated ones) after alignment, for plots/export.
  std::vector<StampedPose> aligned_estimate;
};

// Throws InputError if fewer than 3 pairs can be associated.
AteResult ComputeAte(const std::vector<StampedPose>& groundtruth,
                     const std::vector<StampedPose>& estimate, const AteOptions& options = {});

// "t gt_x gt_y gt_z est_x est_y est_z error" per associated pair, with a header comment line (the
// input of scripts/plot_trajectory.py and the bench plots).
std::string AtePairsText(const AteResult& ate);

// Closed-form rigid alignment minimising sum ||target_i - (R * source_i + t)||^2 (Horn 1987 /
// Umeyama 1991 without scale). Requires >= 3 points (throws std::invalid_argument otherwise).
Rigid3d AlignRigid(const std::vector<Eigen::Vector3d>& source,
                   const std::vector<Eigen::Vector3d>& target);

struct RpeOptions {
  double delta = 1.0;   // seconds
  double offset = 0.0;  // seconds added to estimate stamps
  void Check() const;
};

struct RpeResult {
  size_t num_pairs = 0;  // 0 when the trajectory is shorter than delta
  double delta = 1.0;
  // Translation error per delta (m per delta s; m/s for delta = 1 s).
  double trans_rmse = 0, trans_mean = 0, trans_median = 0;
  // Rotation error per delta (degrees per delta s).
  double rot_rmse = 0, rot_mean = 0, rot_median = 0;
  std::vector<double> trans_errors, rot_errors;  // per pair
};

RpeResult ComputeRpe(const std::vector<StampedPose>& groundtruth,
                     const std::vector<StampedPose>& estimate, const RpeOptions& options = {});

// Ground truth of a rigid body other than the camera (a motion-capture marker body) moved to the
// camera: world_from_cam = world_from_body * body_from_cam for every pose. ATE with rigid
// alignment barely depends on it (only the lever arm between body and camera); RPE does: the
// relative motion of the body, expressed in the body's axes, is compared with the camera's
// relative motion in the camera's axes, so without it RPE measures the body-to-camera rotation.
std::vector<StampedPose> MoveGroundTruthToCamera(const std::vector<StampedPose>& groundtruth,
                                                 const Rigid3d& body_from_cam);

// The Bonn RGB-D Dynamic dataset's marker-to-camera calibration, as the dataset's page publishes
// it for its groundtruth.txt (the pose of the motion-capture marker body):
//   T_camera = T_ros * T_marker * T_ros * T_m,  T_ros = [-1 0 0 0; 0 0 1 0; 0 1 0 0; 0 0 0 1],
//   T_m = [1.0157 0.1828 -0.2389 0.0113; 0.0009 -0.8431 -0.6413 -0.0098;
//          -0.3009 0.6147 -0.8085 0.0111; 0 0 0 1].
// The left T_ros only turns the world's axes (no effect on ATE or RPE), so the body_from_cam of
// MoveGroundTruthToCamera is T_ros * T_m. T_m's 3x3 block is a rotation scaled by 1.0593 (the
// dataset's transform also brings its reconstructions to the scale of its reference model); the
// rotation is the nearest one (polar decomposition), the translation is kept.
Rigid3d BonnMarkerFromCamera();

}  // namespace dygslam
