// Residuals for pose-only optimisation and bundle adjustment, with analytic Jacobians.
//
// Pose parameter block (7 doubles): [tx ty tz qx qy qz qw] of cam_from_world.
// Tangent (6): [dt, dtheta] with the left update  R' = Exp(dtheta) R,  t' = Exp(dtheta) t + dt,
// i.e. T' = [Exp(dtheta) | dt] * T. With p_cam = R X + t this gives
//   d p_cam / d dt = I,   d p_cam / d dtheta = -[p_cam]x,   d p_cam / d X = R.
// Cost functions report ambient Jacobians whose first 6 columns are the tangent Jacobian and whose
// last column is zero; PoseManifold::PlusJacobian is [I6; 0], so Ceres sees the tangent Jacobian.
#pragma once

#include <ceres/ceres.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/base/rigid3.h"
#include "core/slam/optimize/projection_model.h"

namespace dygslam {

void PoseToParameters(const Rigid3d& cam_from_world, double* params7);
Rigid3d PoseFromParameters(const double* params7);
Eigen::Matrix3d SkewSymmetric(const Eigen::Vector3d& v);
Eigen::Quaterniond ExpSO3(const Eigen::Vector3d& omega);

class PoseManifold : public ceres::Manifold {
 public:
  int AmbientSize() const override { return 7; }
  int TangentSize() const override { return 6; }
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  bool PlusJacobian(const double* x, double* jacobian) const override;
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  bool MinusJacobian(const double* x, double* jacobian) const override;
};

// Reprojection residual of kRows rows, pose only (the point X is constant):
//   kRows = 2, monocular:         r = (obs - pi(R X + t)) * sqrt_info;
//   kRows = 3, RGB-D "stereo":    r = ([u, v, u_right] - [pi(p), pi_x(p) - bf / z]) * sqrt_info.
template <int kRows>
class PoseReprojectionCost : public ceres::SizedCostFunction<kRows, 7> {
 public:
  using Observation = Eigen::Matrix<double, kRows, 1>;
  PoseReprojectionCost(const Observation& obs, const Eigen::Vector3d& point, double sqrt_info,
                       const ProjectionModel& model)
      : obs_(obs), point_(point), sqrt_info_(sqrt_info), model_(model) {}
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Observation obs_;
  Eigen::Vector3d point_;
  double sqrt_info_;
  ProjectionModel model_;
};
using MonoPoseCost = PoseReprojectionCost<2>;
using StereoPoseCost = PoseReprojectionCost<3>;

// Bundle adjustment versions of the same residuals: parameter blocks pose (7) and point (3).
template <int kRows>
class BundleReprojectionCost : public ceres::SizedCostFunction<kRows, 7, 3> {
 public:
  using Observation = Eigen::Matrix<double, kRows, 1>;
  BundleReprojectionCost(const Observation& obs, double sqrt_info, const ProjectionModel& model)
      : obs_(obs), sqrt_info_(sqrt_info), model_(model) {}
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Observation obs_;
  double sqrt_info_;
  ProjectionModel model_;
};
using MonoBACost = BundleReprojectionCost<2>;
using StereoBACost = BundleReprojectionCost<3>;

// A prior on a pose (cam_from_world) at `prior`: the error of T T0^-1 in the tangent of the left
// update, e = [t - dR t0, log(dR)] with dR = R R0^-1 (metres, radians). Its Jacobian with respect
// to the tangent is taken as the identity: exact at T = T0, first order near it (a prior holds a
// pose near its value).
Eigen::Matrix<double, 6, 1> PosePriorError(const Rigid3d& cam_from_world, const Rigid3d& prior);

// The information matrix of a pose prior (order of PosePriorError: translation, rotation) that
// acts only in the directions `information` (of the pose's observations) leaves nearly free: the
// eigen-directions of `information` whitened by the prior's standard deviations whose eigenvalue
// is below 1 (less information than the prior's) get the prior; the others none.
Eigen::Matrix<double, 6, 6> PriorInWeakDirections(const Eigen::Matrix<double, 6, 6>& information,
                                                  double sigma_translation, double sigma_rotation);

// Instantiated once, in cost_functions.cc.
extern template class PoseReprojectionCost<2>;
extern template class PoseReprojectionCost<3>;
extern template class BundleReprojectionCost<2>;
extern template class BundleReprojectionCost<3>;

}  // namespace dygslam
