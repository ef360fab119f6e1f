// A small dedicated solver for tracking's pose-only optimisation: Levenberg-Marquardt on SE3 over
// reprojection residuals (monocular 2 rows, RGB-D "stereo" 3 rows) with an optional Huber kernel.
//
// Why not Ceres: tracking solves 4 rounds of <= 10 iterations per frame over a single 6-dof
// block; building a new ceres::Problem per round (a cost function and a loss per residual) cost
// more than the solve itself (measured by profiling). Here the normal equations are a fixed-size
// 6x6 system accumulated in one pass over the observations, and nothing is allocated per iteration.
//
// The model is the one of core/slam/optimize/cost_functions.h (so results match the Ceres version
// within the solvers' tolerances): residual r = (obs - proj(R X + t)) * sqrt_info, left update T' =
// [Exp(dtheta) | dt] * T, Huber kernel rho(s) = s for s <= delta^2, 2 delta sqrt(s) - delta^2
// otherwise, applied as iteratively reweighted least squares. The trust region follows Ceres'
// Levenberg-Marquardt defaults (damping diag(H) / radius, radius 1e4, accepted when the cost drops,
// radius grown by 1 / max(1/3, 1 - (2 rho - 1)^3), halved with doubling decrease on a rejection),
// and the same stopping rules (function tolerance 1e-6, gradient 1e-10, parameter 1e-8).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "core/base/rigid3.h"
#include "core/slam/optimize/cost_functions.h"
#include "core/slam/optimize/trust_region.h"

namespace dygslam {

// One residual: a fixed world point, its measurement (u, v[, u_right]) and its weight.
struct PoseObservation {
  Eigen::Vector3d point;        // world
  Eigen::Vector3d measurement;  // u, v, u_right (u_right unused when !stereo)
  double information = 1.0;     // 1 / sigma^2 of the keypoint's octave
  bool stereo = false;
};

// A Gaussian prior on the pose: PosePriorError(cam_from_world, prior) weighted by `information`
// (translation, rotation order).
struct PosePrior {
  Rigid3d cam_from_world;
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Zero();
};

struct PoseSolverOptions : TrustRegionOptions {
  void Check() const;
};
using PoseSolverSummary = TrustRegionSummary;

// Optimises cam_from_world over the observations whose `active` flag is set (active may be
// nullptr: all). `huber_delta_mono` / `huber_delta_stereo` <= 0: no kernel (plain least squares).
PoseSolverSummary SolvePose(const std::vector<PoseObservation>& observations, const uint8_t* active,
                            const ProjectionModel& model, double huber_delta_mono,
                            double huber_delta_stereo, const PoseSolverOptions& options,
                            Rigid3d* cam_from_world, const PosePrior* prior = nullptr);

// The information (Gauss-Newton normal matrix, in the solver's tangent order: translation,
// rotation) of the active observations at `cam_from_world`, with the same kernel weights.
Eigen::Matrix<double, 6, 6> PoseInformation(const std::vector<PoseObservation>& observations,
                                            const uint8_t* active, const ProjectionModel& model,
                                            double huber_delta_mono, double huber_delta_stereo,
                                            const Rigid3d& cam_from_world);

}  // namespace dygslam
