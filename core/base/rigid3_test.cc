#include "core/base/rigid3.h"

#include <gtest/gtest.h>

namespace dygslam {
namespace {

TEST(Rigid3d, ComposeAndInverse) {
  Rigid3d a_from_b(Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized())),
                   Eigen::Vector3d(1, -2, 0.5));
  Rigid3d b_from_c(Eigen::Quaterniond(Eigen::AngleAxisd(-1.1, Eigen::Vector3d(0, 1, 0))),
                   Eigen::Vector3d(0.2, 0.1, -3));
  const Eigen::Vector3d x(0.7, -0.4, 2.0);
  EXPECT_TRUE(((a_from_b * b_from_c) * x).isApprox(a_from_b * (b_from_c * x), 1e-12));
  EXPECT_TRUE((a_from_b.Inverse() * (a_from_b * x)).isApprox(x, 1e-12));
  EXPECT_NEAR(RotationAngle(Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()))), 0.3, 1e-12);
}

}  // namespace
}  // namespace dygslam
