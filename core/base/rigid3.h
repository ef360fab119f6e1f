// Rigid transform target_from_source: x_target = rotation * x_source + translation.
// Naming convention everywhere: `cam_from_world`, `world_from_cam`, ...
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace dygslam {

struct Rigid3d {
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  Rigid3d() = default;
  Rigid3d(const Eigen::Quaterniond& r, const Eigen::Vector3d& t) : rotation(r.normalized()), translation(t) {}
  Rigid3d(const Eigen::Matrix3d& r, const Eigen::Vector3d& t) : rotation(Eigen::Quaterniond(r).normalized()), translation(t) {}

  static Rigid3d Identity() { return Rigid3d(); }

  Rigid3d Inverse() const {
    const Eigen::Quaterniond inv = rotation.conjugate();
    return Rigid3d(inv, -(inv * translation));
  }
  Eigen::Vector3d operator*(const Eigen::Vector3d& x) const { return rotation * x + translation; }
  // (a_from_b * b_from_c) = a_from_c
  Rigid3d operator*(const Rigid3d& other) const {
    return Rigid3d(rotation * other.rotation, rotation * other.translation + translation);
  }
  Eigen::Matrix4d ToMatrix() const {
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topLeftCorner<3, 3>() = rotation.toRotationMatrix();
    m.topRightCorner<3, 1>() = translation;
    return m;
  }
  Eigen::Matrix3d RotationMatrix() const { return rotation.toRotationMatrix(); }
  bool AllFinite() const {
    return rotation.coeffs().allFinite() && translation.allFinite();
  }
};

// Rotation angle of a relative rotation in radians, in [0, pi].
inline double RotationAngle(const Eigen::Quaterniond& q) {
  const double w = std::min(1.0, std::abs(q.normalized().w()));
  return 2.0 * std::acos(w);
}

}  // namespace dygslam
