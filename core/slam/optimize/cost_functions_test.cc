// Every cost function against numerical derivatives taken through the manifold's Plus.
#include "core/slam/optimize/cost_functions.h"

#include <random>

#include <gtest/gtest.h>

namespace dygslam {
namespace {

const ProjectionModel kModel{525.0, 523.0, 319.5, 239.5, 40.0};

Rigid3d RandomPose(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  Eigen::Vector3d axis(u(rng), u(rng), u(rng));
  return Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.3 * u(rng), axis.normalized())),
                 Eigen::Vector3d(0.2 * u(rng), 0.2 * u(rng), 0.2 * u(rng)));
}

// Numerical tangent Jacobian of a cost w.r.t. the pose (via PoseManifold::Plus) and, if present,
// the point (plain finite differences).
template <int kRows>
void CheckAgainstNumeric(const ceres::CostFunction& cost, double* pose, double* point) {
  PoseManifold manifold;
  std::vector<double*> params = {pose};
  if (point) params.push_back(point);
  double residual[kRows];
  double j_pose[kRows * 7];
  double j_point[kRows * 3];
  double* jacobians[2] = {j_pose, j_point};
  ASSERT_TRUE(cost.Evaluate(params.data(), residual, jacobians));
  double plus_jacobian[7 * 6];
  manifold.PlusJacobian(pose, plus_jacobian);
  const Eigen::Map<Eigen::Matrix<double, kRows, 7, Eigen::RowMajor>> ja(j_pose);
  const Eigen::Map<Eigen::Matrix<double, 7, 6, Eigen::RowMajor>> jp(plus_jacobian);
  const Eigen::Matrix<double, kRows, 6> analytic = ja * jp;
  const double h = 1e-6;
  for (int k = 0; k < 6; ++k) {
    double delta[6] = {0, 0, 0, 0, 0, 0};
    double plus[7], minus[7];
    delta[k] = h;
    manifold.Plus(pose, delta, plus);
    delta[k] = -h;
    manifold.Plus(pose, delta, minus);
    double rp[kRows], rm[kRows];
    std::vector<double*> pp = {plus}, pm = {minus};
    if (point) {
      pp.push_back(point);
      pm.push_back(point);
    }
    ASSERT_TRUE(cost.Evaluate(pp.data(), rp, nullptr));
    ASSERT_TRUE(cost.Evaluate(pm.data(), rm, nullptr));
    for (int r = 0; r < kRows; ++r) {
      const double numeric = (rp[r] - rm[r]) / (2 * h);
      EXPECT_NEAR(analytic(r, k), numeric, 1e-4 * std::max(1.0, std::abs(numeric))) << "row " << r << " col " << k;
    }
  }
  if (point) {
    const Eigen::Map<Eigen::Matrix<double, kRows, 3, Eigen::RowMajor>> jx(j_point);
    for (int k = 0; k < 3; ++k) {
      double xp[3] = {point[0], point[1], point[2]}, xm[3] = {point[0], point[1], point[2]};
      xp[k] += h;
      xm[k] -= h;
      double rp[kRows], rm[kRows];
      double* pp[2] = {pose, xp};
      double* pm[2] = {pose, xm};
      ASSERT_TRUE(cost.Evaluate(pp, rp, nullptr));
      ASSERT_TRUE(cost.Evaluate(pm, rm, nullptr));
      for (int r = 0; r < kRows; ++r) {
        const double numeric = (rp[r] - rm[r]) / (2 * h);
        EXPECT_NEAR(jx(r, k), numeric, 1e-4 * std::max(1.0, std::abs(numeric)));
      }
    }
  }
}

TEST(CostFunctions, MonoPoseMatchesNumeric) {
  std::mt19937 rng(1);
  for (int trial = 0; trial < 20; ++trial) {
    const Rigid3d pose = RandomPose(rng);
    const Eigen::Vector3d x = pose.Inverse() * Eigen::Vector3d(0.3, -0.2, 2.5 + trial * 0.1);
    double params[7];
    PoseToParameters(pose, params);
    MonoPoseCost cost(Eigen::Vector2d(300, 250), x, 0.8, kModel);
    CheckAgainstNumeric<2>(cost, params, nullptr);
  }
}

TEST(CostFunctions, StereoPoseMatchesNumeric) {
  std::mt19937 rng(2);
  for (int trial = 0; trial < 20; ++trial) {
    const Rigid3d pose = RandomPose(rng);
    const Eigen::Vector3d x = pose.Inverse() * Eigen::Vector3d(-0.5, 0.4, 1.5 + trial * 0.2);
    double params[7];
    PoseToParameters(pose, params);
    StereoPoseCost cost(Eigen::Vector3d(300, 250, 280), x, 1.2, kModel);
    CheckAgainstNumeric<3>(cost, params, nullptr);
  }
}

TEST(CostFunctions, BundleAdjustmentCostsMatchNumeric) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 20; ++trial) {
    const Rigid3d pose = RandomPose(rng);
    Eigen::Vector3d x = pose.Inverse() * Eigen::Vector3d(0.1 * trial, -0.3, 2.0 + 0.1 * trial);
    double params[7];
    PoseToParameters(pose, params);
    MonoBACost mono(Eigen::Vector2d(310, 200), 1.0, kModel);
    CheckAgainstNumeric<2>(mono, params, x.data());
    StereoBACost stereo(Eigen::Vector3d(310, 200, 290), 0.7, kModel);
    CheckAgainstNumeric<3>(stereo, params, x.data());
  }
}

TEST(CostFunctions, ResidualIsZeroAtTruth) {
  const Rigid3d pose(Eigen::Quaterniond(Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitY())), Eigen::Vector3d(0.1, 0, 0.3));
  const Eigen::Vector3d x(0.4, 0.2, 3.0);
  const Eigen::Vector3d p = pose * x;
  const double u = kModel.fx * p.x() / p.z() + kModel.cx, v = kModel.fy * p.y() / p.z() + kModel.cy;
  double params[7];
  PoseToParameters(pose, params);
  StereoPoseCost cost(Eigen::Vector3d(u, v, u - kModel.bf / p.z()), x, 1.0, kModel);
  double r[3];
  double* blocks[1] = {params};
  ASSERT_TRUE(cost.Evaluate(blocks, r, nullptr));
  EXPECT_NEAR(r[0], 0, 1e-9);
  EXPECT_NEAR(r[1], 0, 1e-9);
  EXPECT_NEAR(r[2], 0, 1e-9);
  // A 1 px offset in u gives a residual of -sqrt_info (obs - prediction).
  StereoPoseCost shifted(Eigen::Vector3d(u + 1, v, u - kModel.bf / p.z()), x, 2.0, kModel);
  ASSERT_TRUE(shifted.Evaluate(blocks, r, nullptr));
  EXPECT_NEAR(r[0], 2.0, 1e-9);
}

TEST(PoseManifold, PlusMinusRoundTrip) {
  std::mt19937 rng(4);
  PoseManifold m;
  for (int trial = 0; trial < 10; ++trial) {
    double x[7];
    PoseToParameters(RandomPose(rng), x);
    const double delta[6] = {0.01, -0.02, 0.03, 0.05, -0.01, 0.02};
    double y[7], back[6];
    m.Plus(x, delta, y);
    m.Minus(y, x, back);
    for (int k = 0; k < 6; ++k) EXPECT_NEAR(back[k], delta[k], 1e-9);
  }
}

}  // namespace
}  // namespace dygslam
