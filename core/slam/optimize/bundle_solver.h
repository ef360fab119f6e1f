// A dedicated solver for the local bundle adjustment: Levenberg-Marquardt over keyframe poses
// (SE3) and map points with the points eliminated by a Schur complement, on the residuals of
// core/slam/optimize/cost_functions.h (monocular 2 rows, RGB-D "stereo" 3 rows) with an optional
// Huber kernel applied as iteratively reweighted least squares.
//
// Why not Ceres for the local window: a local BA is ~20 poses, ~2,000 points and ~6,500
// observations, solved after every keyframe. Ceres spent most of its time on building the problem
// twice per keyframe (a residual block per observation, hash maps of parameter blocks) and on its
// general block machinery; here the structure is indexed once, the reduced camera system is a
// small dense matrix (6 x variable poses) accumulated point by point, with no per-residual
// objects. Global bundle adjustments (hundreds of poses, a sparse camera system) stay on Ceres.
//
// The trust region follows Ceres' Levenberg-Marquardt defaults as SolvePose does
// (core/slam/optimize/pose_solver.h): damping diag(H) / radius, radius 1e4 at first, grown by
// 1 / max(1/3, 1 - (2 rho - 1)^3) on an accepted step, halved with doubling decrease on a rejected
// one; the same stopping rules (function tolerance 1e-6, gradient 1e-10, parameter 1e-8).
#pragma once

#include <Eigen/Core>
#include <array>
#include <atomic>
#include <cstdint>
#include <map>
#include <set>
#include <vector>

#include "core/slam/optimize/projection_model.h"
#include "core/slam/optimize/trust_region.h"

namespace dygslam {

struct BundleSolverOptions : TrustRegionOptions {
  // A prior on every variable pose at its value when the solve starts (PosePriorError in
  // core/slam/optimize/cost_functions.h) in the directions its observations leave nearly free:
  // the eigen-directions of the pose's block of the reduced camera system (points eliminated, the
  // other poses held) at the start, whitened by these standard deviations of translation (metres)
  // and rotation (radians), whose information is below the prior's. Directions the points fix
  // get no prior. 0: none.
  double prior_sigma_translation = 0;
  double prior_sigma_rotation = 0;
  void Check() const;
};
using BundleSolverSummary = TrustRegionSummary;

// One residual of a bundle problem: keyframe `pose` (index into the pose list) sees `point`.
struct BundleResidual {
  int pose = 0;
  int point = 0;
  Eigen::Vector3d measurement;  // u, v, u_right (u_right unused when !stereo)
  double sqrt_info = 1.0;
  bool stereo = false;
};

// Poses are cam_from_world as [tx ty tz qx qy qz qw] (core/slam/optimize/cost_functions.h); the
// ones whose `fixed` flag is set stay where they are. Only residuals whose `active` flag is set
// count (active may be nullptr: all). `huber_delta_*` <= 0: no kernel. `abort` (may be nullptr)
// stops between iterations with the best point so far.
BundleSolverSummary SolveBundleProblem(const std::vector<BundleResidual>& residuals,
                                       const uint8_t* active, const ProjectionModel& model,
                                       double huber_delta_mono, double huber_delta_stereo,
                                       const BundleSolverOptions& options,
                                       const std::vector<uint8_t>& fixed,
                                       std::vector<std::array<double, 7>>* poses,
                                       std::vector<Eigen::Vector3d>* points,
                                       const std::atomic<bool>* abort = nullptr);

}  // namespace dygslam
