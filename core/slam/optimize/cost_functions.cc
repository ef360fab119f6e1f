#include "core/slam/optimize/cost_functions.h"

#include <Eigen/Eigenvalues>
#include <cmath>

namespace dygslam {
namespace {

// Projection of p_cam and its 3x3 Jacobian rows for (u, v, u_right).
struct Projected {
  Eigen::Vector3d uvr;
  Eigen::Matrix3d d_uvr_d_p;
};

Projected Project(const Eigen::Vector3d& p, const ProjectionModel& m) {
  const double inv_z = 1.0 / p.z(), inv_z2 = inv_z * inv_z;
  Projected out;
  const double u = m.fx * p.x() * inv_z + m.cx;
  out.uvr << u, m.fy * p.y() * inv_z + m.cy, u - m.bf * inv_z;
  out.d_uvr_d_p << m.fx * inv_z, 0, -m.fx * p.x() * inv_z2,  //
      0, m.fy * inv_z, -m.fy * p.y() * inv_z2,               //
      m.fx * inv_z, 0, -m.fx * p.x() * inv_z2 + m.bf * inv_z2;
  return out;
}

template <int kRows>
bool EvaluatePose(const double* pose, const Eigen::Vector3d& point,
                  const Eigen::Matrix<double, kRows, 1>& obs, double sqrt_info,
                  const ProjectionModel& model, double* residuals, double* jacobian_pose,
                  double* jacobian_point) {
  const Eigen::Map<const Eigen::Vector3d> t(pose);
  const Eigen::Map<const Eigen::Quaterniond> q(pose + 3);
  const Eigen::Matrix3d rotation = q.toRotationMatrix();
  const Eigen::Vector3d p = rotation * point + t;
  if (p.z() <= 1e-6) {
    // Behind the camera: a constant residual and no gradient (treated as an outlier upstream).
    for (int i = 0; i < kRows; ++i) residuals[i] = 0;
    if (jacobian_pose) std::fill(jacobian_pose, jacobian_pose + kRows * 7, 0.0);
    if (jacobian_point) std::fill(jacobian_point, jacobian_point + kRows * 3, 0.0);
    return true;
  }
  const Projected proj = Project(p, model);
  Eigen::Map<Eigen::Matrix<double, kRows, 1>> r(residuals);
  r = (obs - proj.uvr.template head<kRows>()) * sqrt_info;
  const Eigen::Matrix<double, kRows, 3> d_r_d_p =
      -sqrt_info * proj.d_uvr_d_p.template topRows<kRows>();
  if (jacobian_pose) {
    Eigen::Map<Eigen::Matrix<double, kRows, 7, Eigen::RowMajor>> j(jacobian_pose);
    j.template leftCols<3>() = d_r_d_p;
    j.template middleCols<3>(3) = -d_r_d_p * SkewSymmetric(p);
    j.col(6).setZero();
  }
  if (jacobian_point) {
    Eigen::Map<Eigen::Matrix<double, kRows, 3, Eigen::RowMajor>> j(jacobian_point);
    j = d_r_d_p * rotation;
  }
  return true;
}

}  // namespace

Eigen::Matrix3d SkewSymmetric(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

Eigen::Quaterniond ExpSO3(const Eigen::Vector3d& omega) {
  const double theta = omega.norm();
  if (theta < 1e-10) {
    Eigen::Quaterniond q(1.0, 0.5 * omega.x(), 0.5 * omega.y(), 0.5 * omega.z());
    return q.normalized();
  }
  return Eigen::Quaterniond(Eigen::AngleAxisd(theta, omega / theta));
}

Eigen::Matrix<double, 6, 1> PosePriorError(const Rigid3d& cam_from_world, const Rigid3d& prior) {
  const Eigen::Quaterniond relative = cam_from_world.rotation * prior.rotation.conjugate();
  const Eigen::AngleAxisd angle_axis(relative.normalized());  // angle in [0, pi]
  Eigen::Matrix<double, 6, 1> e;
  e.head<3>() = cam_from_world.translation - relative * prior.translation;
  e.tail<3>() = angle_axis.angle() * angle_axis.axis();
  return e;
}

Eigen::Matrix<double, 6, 6> PriorInWeakDirections(const Eigen::Matrix<double, 6, 6>& information,
                                                  double sigma_translation, double sigma_rotation) {
  using Matrix6d = Eigen::Matrix<double, 6, 6>;
  Eigen::Matrix<double, 6, 1> sigma;
  sigma << Eigen::Vector3d::Constant(sigma_translation), Eigen::Vector3d::Constant(sigma_rotation);
  const Matrix6d whitened = sigma.asDiagonal() * information * sigma.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eigen(whitened);
  Matrix6d weak = Matrix6d::Zero();
  for (int d = 0; d < 6; ++d) {
    if (eigen.eigenvalues()(d) < 1.0)
      weak += eigen.eigenvectors().col(d) * eigen.eigenvectors().col(d).transpose();
  }
  const Eigen::Matrix<double, 6, 1> inverse_sigma = sigma.cwiseInverse();
  return inverse_sigma.asDiagonal() * weak * inverse_sigma.asDiagonal();
}

void PoseToParameters(const Rigid3d& cam_from_world, double* params7) {
  params7[0] = cam_from_world.translation.x();
  params7[1] = cam_from_world.translation.y();
  params7[2] = cam_from_world.translation.z();
  const Eigen::Quaterniond q = cam_from_world.rotation.normalized();
  params7[3] = q.x();
  params7[4] = q.y();
  params7[5] = q.z();
  params7[6] = q.w();
}

Rigid3d PoseFromParameters(const double* p) {
  return Rigid3d(Eigen::Quaterniond(p[6], p[3], p[4], p[5]), Eigen::Vector3d(p[0], p[1], p[2]));
}

bool PoseManifold::Plus(const double* x, const double* delta, double* x_plus_delta) const {
  const Eigen::Map<const Eigen::Vector3d> t(x), dt(delta), dtheta(delta + 3);
  const Eigen::Map<const Eigen::Quaterniond> q(x + 3);
  const Eigen::Quaterniond dq = ExpSO3(dtheta);
  Eigen::Map<Eigen::Vector3d> t_out(x_plus_delta);
  Eigen::Map<Eigen::Quaterniond> q_out(x_plus_delta + 3);
  t_out = dq * t + dt;
  q_out = (dq * q).normalized();
  return true;
}

bool PoseManifold::PlusJacobian(const double* x, double* jacobian) const {
  Eigen::Map<Eigen::Matrix<double, 7, 6, Eigen::RowMajor>> j(jacobian);
  j.setZero();
  j.topRows<6>().setIdentity();
  return true;
}

bool PoseManifold::Minus(const double* y, const double* x, double* y_minus_x) const {
  const Eigen::Map<const Eigen::Vector3d> tx(x), ty(y);
  const Eigen::Map<const Eigen::Quaterniond> qx(x + 3), qy(y + 3);
  const Eigen::Quaterniond dq = (qy * qx.conjugate()).normalized();
  const Eigen::AngleAxisd aa(dq);
  const Eigen::Vector3d dtheta = aa.angle() * aa.axis();
  Eigen::Map<Eigen::Vector3d> dt_out(y_minus_x), dtheta_out(y_minus_x + 3);
  dt_out = ty - dq * tx;
  dtheta_out = dtheta;
  return true;
}

bool PoseManifold::MinusJacobian(const double* x, double* jacobian) const {
  Eigen::Map<Eigen::Matrix<double, 6, 7, Eigen::RowMajor>> j(jacobian);
  j.setZero();
  j.leftCols<6>().setIdentity();
  return true;
}

template <int kRows>
bool PoseReprojectionCost<kRows>::Evaluate(double const* const* parameters, double* residuals,
                                           double** jacobians) const {
  return EvaluatePose<kRows>(parameters[0], point_, obs_, sqrt_info_, model_, residuals,
                             jacobians ? jacobians[0] : nullptr, nullptr);
}

template <int kRows>
bool BundleReprojectionCost<kRows>::Evaluate(double const* const* parameters, double* residuals,
                                             double** jacobians) const {
  const Eigen::Map<const Eigen::Vector3d> point(parameters[1]);
  return EvaluatePose<kRows>(parameters[0], point, obs_, sqrt_info_, model_, residuals,
                             jacobians ? jacobians[0] : nullptr,
                             jacobians ? jacobians[1] : nullptr);
}

template class PoseReprojectionCost<2>;
template class PoseReprojectionCost<3>;
template class BundleReprojectionCost<2>;
template class BundleReprojectionCost<3>;

}  // namespace dygslam
