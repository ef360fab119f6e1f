#include "core/slam/optimize/pose_graph.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

namespace dygslam {
namespace {

// Poses on a circle of radius 3 m (20 nodes), camera looking outward.
Rigid3d CirclePose(int k, int n) {
  const double th = 2 * M_PI * k / n;
  const Eigen::Matrix3d r = Eigen::AngleAxisd(th, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Rigid3d world_from_cam(r, Eigen::Vector3d(3 * std::cos(th), 3 * std::sin(th), 1.0));
  return world_from_cam.Inverse();
}

TEST(PoseGraph, LoopEdgeRemovesAccumulatedDrift) {
  constexpr int n = 20;
  std::map<int64_t, Rigid3d> truth, drifted;
  for (int k = 0; k < n; ++k) truth[k] = CirclePose(k, n);
  // Odometry edges with a small bias per step (a tilt and a forward/up offset, as visual odometry
  // drifts); the initial guess chains them.
  std::vector<PoseGraphEdge> edges;
  const Rigid3d bias(Eigen::Quaterniond(Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitY())),
                     Eigen::Vector3d(0.02, 0.0, 0.01));
  for (int k = 1; k < n; ++k) edges.push_back({k, k - 1, bias * truth[k] * truth[k - 1].Inverse(), 1.0});
  drifted[0] = truth[0];
  for (int k = 1; k < n; ++k) drifted[k] = edges[k - 1].i_from_j * drifted[k - 1];
  auto error = [&](const std::map<int64_t, Rigid3d>& poses) {
    double worst = 0;
    for (int k = 0; k < n; ++k)
      worst = std::max(worst, (poses.at(k).Inverse().translation - truth[k].Inverse().translation).norm());
    return worst;
  };
  const double before = error(drifted);
  // Without a loop edge the drifted chain already satisfies every edge: nothing moves.
  std::map<int64_t, Rigid3d> no_loop = drifted;
  OptimizePoseGraph(&no_loop, edges, {0}, 20);
  // The loop edge (last node seen again from the first, measured exactly) closes the circle: the
  // drift is spread over the 20 odometry edges.
  edges.push_back({n - 1, 0, truth[n - 1] * truth[0].Inverse(), 1.0});
  std::map<int64_t, Rigid3d> closed = drifted;
  const PoseGraphSummary summary = OptimizePoseGraph(&closed, edges, {0}, 50);
  const double after = error(closed);
  std::printf("pose graph: worst position error %.3f m drifted, %.3f m after closing (cost %.3g -> %.3g)\n",
              before, after, summary.initial_cost, summary.final_cost);
  EXPECT_GT(before, 0.3);
  EXPECT_LT(after, before / 3);  // measured 0.79 m -> 0.12 m
  EXPECT_LT(summary.final_cost, summary.initial_cost / 10);
  EXPECT_NEAR((closed.at(0).translation - drifted.at(0).translation).norm(), 0.0, 1e-12);  // fixed
  EXPECT_NEAR(error(no_loop), before, 1e-6);
}

TEST(PoseGraph, EdgesToUnknownNodesAreSkipped) {
  std::map<int64_t, Rigid3d> poses = {{0, Rigid3d::Identity()}};
  const PoseGraphSummary s = OptimizePoseGraph(&poses, {{0, 7, Rigid3d::Identity(), 1.0}}, {0}, 5);
  EXPECT_EQ(s.iterations, 0);
  EXPECT_TRUE(poses.at(0).AllFinite());
}

}  // namespace
}  // namespace dygslam
