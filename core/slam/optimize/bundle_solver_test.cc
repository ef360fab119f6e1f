// The dedicated bundle solver on generated local windows, against Ceres on the same problem.
#include "core/slam/optimize/bundle_solver.h"

#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include <iostream>
#include <memory>
#include <random>

#include "core/slam/optimize/cost_functions.h"

namespace dygslam {
namespace {

BundleSolverOptions Iterations(int n) {
  BundleSolverOptions options;
  options.max_iterations = n;
  return options;
}

const ProjectionModel kModel{525.0, 525.0, 319.5, 239.5, 40.0};

// A camera walking along x looking along z at points 2-6 m away; the first `fixed` poses are
// fixed (the gauge). Each point is seen by the cameras that have it in view.
struct Window {
  std::vector<Rigid3d> truth;  // cam_from_world
  std::vector<Eigen::Vector3d> points;
  std::vector<BundleResidual> residuals;
  std::vector<uint8_t> fixed;
};

Window MakeWindow(int cameras, int points, int fixed, double noise_px, double wrong_share,
                  uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> x(-2.0, 2.0 + 0.15 * cameras), y(-1.2, 1.2), z(2.0, 6.0),
      u01(0, 1), upix(0, 640), vpix(0, 480);
  std::normal_distribution<double> noise(0, noise_px);
  Window w;
  for (int k = 0; k < cameras; ++k) {
    const Rigid3d world_from_cam(
        Eigen::Quaterniond(Eigen::AngleAxisd(0.02 * k, Eigen::Vector3d::UnitY())),
        Eigen::Vector3d(0.15 * k, 0.01 * k, 0.02 * k));
    w.truth.push_back(world_from_cam.Inverse());
    w.fixed.push_back(k < fixed ? 1 : 0);
  }
  for (int p = 0; p < points; ++p) w.points.emplace_back(x(rng), y(rng), z(rng));
  for (int p = 0; p < points; ++p) {
    for (int k = 0; k < cameras; ++k) {
      const Eigen::Vector3d c = w.truth[k] * w.points[p];
      const double u = kModel.fx * c.x() / c.z() + kModel.cx;
      const double v = kModel.fy * c.y() / c.z() + kModel.cy;
      if (c.z() < 0.5 || u < 0 || u >= 640 || v < 0 || v >= 480) continue;
      BundleResidual r;
      r.pose = k;
      r.point = p;
      r.stereo = (p + k) % 3 != 0;
      r.sqrt_info = 1.0 / std::pow(1.2, (p + 2 * k) % 4);
      const bool wrong = u01(rng) < wrong_share;
      const double mu = wrong ? upix(rng) : u + noise(rng);
      const double mv = wrong ? vpix(rng) : v + noise(rng);
      r.measurement = Eigen::Vector3d(mu, mv, mu - kModel.bf / c.z() + (wrong ? 0 : noise(rng)));
      w.residuals.push_back(r);
    }
  }
  return w;
}

// Start values: the variable poses moved by a few cm and degrees, every point by a few cm.
void Perturb(const Window& w, uint32_t seed, std::vector<std::array<double, 7>>* poses,
             std::vector<Eigen::Vector3d>* points) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0, 1);
  poses->resize(w.truth.size());
  for (size_t k = 0; k < w.truth.size(); ++k) {
    Rigid3d pose = w.truth[k];
    if (!w.fixed[k]) {
      const Eigen::Vector3d axis(n(rng), n(rng), n(rng));
      pose = Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.02, axis.normalized())),
                     Eigen::Vector3d(0.03 * n(rng), 0.03 * n(rng), 0.03 * n(rng))) *
             pose;
    }
    PoseToParameters(pose, (*poses)[k].data());
  }
  *points = w.points;
  for (Eigen::Vector3d& p : *points) p += 0.03 * Eigen::Vector3d(n(rng), n(rng), n(rng));
}

// The same problem with Ceres (the cost functions the local BA used before); its final cost.
double SolveWithCeres(const Window& w, bool robust, int iterations,
                      std::vector<std::array<double, 7>>* poses,
                      std::vector<Eigen::Vector3d>* points) {
  ceres::Problem problem;
  for (const BundleResidual& r : w.residuals) {
    ceres::CostFunction* cost = r.stereo
                                    ? static_cast<ceres::CostFunction*>(
                                          new StereoBACost(r.measurement, r.sqrt_info, kModel))
                                    : new MonoBACost(r.measurement.head<2>(), r.sqrt_info, kModel);
    ceres::LossFunction* loss =
        robust ? new ceres::HuberLoss(std::sqrt(r.stereo ? 7.815 : 5.991)) : nullptr;
    problem.AddResidualBlock(cost, loss, (*poses)[r.pose].data(), (*points)[r.point].data());
  }
  for (size_t k = 0; k < poses->size(); ++k) {
    if (!problem.HasParameterBlock((*poses)[k].data())) continue;
    problem.SetManifold((*poses)[k].data(), new PoseManifold);
    if (w.fixed[k]) problem.SetParameterBlockConstant((*poses)[k].data());
  }
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_SCHUR;
  options.max_num_iterations = iterations;
  options.num_threads = 1;
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  return summary.final_cost;
}

double MaxPoseError(const Window& w, const std::vector<std::array<double, 7>>& poses) {
  double worst = 0;
  for (size_t k = 0; k < poses.size(); ++k) {
    const Rigid3d diff = PoseFromParameters(poses[k].data()) * w.truth[k].Inverse();
    worst = std::max(worst, diff.translation.norm());
  }
  return worst;
}

TEST(BundleSolver, NoiseFreeWindowReturnsToTheTruth) {
  const Window w = MakeWindow(8, 300, 2, 0.0, 0.0, 1);
  std::vector<std::array<double, 7>> poses;
  std::vector<Eigen::Vector3d> points;
  Perturb(w, 2, &poses, &points);
  ASSERT_GT(MaxPoseError(w, poses), 0.02);
  const BundleSolverSummary s = SolveBundleProblem(w.residuals, nullptr, kModel, 0, 0,
                                                   Iterations(20), w.fixed, &poses, &points);
  EXPECT_GT(s.successful_iterations, 2);
  EXPECT_LT(s.final_cost, 1e-8 * s.initial_cost);
  EXPECT_LT(MaxPoseError(w, poses), 1e-6);
  // Points with two observations or more (one monocular ray leaves the depth free).
  std::vector<int> seen(points.size(), 0);
  for (const BundleResidual& r : w.residuals) seen[r.point] += r.stereo ? 2 : 1;
  for (size_t p = 0; p < points.size(); ++p)
    if (seen[p] >= 2) EXPECT_LT((points[p] - w.points[p]).norm(), 1e-5) << "point " << p;
  // The fixed poses did not move.
  for (int k = 0; k < 2; ++k) {
    const Rigid3d pose = PoseFromParameters(poses[k].data());
    EXPECT_LT((pose.translation - w.truth[k].translation).norm(), 1e-12);
  }
}

// Noisy observations with 5 % wrong matches, Huber kernel: the same minimum as Ceres (cost within
// 0.1 %, poses within 3 mm: the kernel is applied as reweighting here and with Ceres' curvature
// correction there, so the two stop at slightly different points of a flat minimum, up to 1.2 mm
// apart on these seeds), and the outlier-free second round lands on the truth within noise.
TEST(BundleSolver, ReachesTheMinimumCeresFinds) {
  for (uint32_t seed : {3u, 4u, 5u}) {
    const Window w = MakeWindow(12, 600, 2, 1.0, 0.05, seed);
    std::vector<std::array<double, 7>> start_poses, poses, ceres_poses;
    std::vector<Eigen::Vector3d> start_points, points, ceres_points;
    Perturb(w, seed + 10, &start_poses, &start_points);
    poses = ceres_poses = start_poses;
    points = ceres_points = start_points;
    const double huber_mono = std::sqrt(5.991), huber_stereo = std::sqrt(7.815);
    const BundleSolverSummary s =
        SolveBundleProblem(w.residuals, nullptr, kModel, huber_mono, huber_stereo, Iterations(30),
                           w.fixed, &poses, &points);
    const double ceres_cost = SolveWithCeres(w, true, 30, &ceres_poses, &ceres_points);
    EXPECT_NEAR(s.final_cost, ceres_cost, 1e-3 * ceres_cost) << "seed " << seed;
    for (size_t k = 0; k < poses.size(); ++k) {
      const Rigid3d a = PoseFromParameters(poses[k].data());
      const Rigid3d b = PoseFromParameters(ceres_poses[k].data());
      EXPECT_LT((a.translation - b.translation).norm(), 3e-3) << "seed " << seed << " pose " << k;
    }
    EXPECT_LT(MaxPoseError(w, poses), 0.02) << "seed " << seed;
  }
}

// Only active residuals count: with the wrong matches switched off, the estimate is the truth
// within noise, and clearly closer than with them in and no kernel.
TEST(BundleSolver, InactiveResidualsAreLeftOut) {
  const Window w = MakeWindow(10, 500, 2, 0.5, 0.15, 7);
  // Which residuals are wrong: regenerate the noise-free window and compare measurements.
  const Window clean = MakeWindow(10, 500, 2, 0.0, 0.0, 7);
  ASSERT_EQ(clean.residuals.size(), w.residuals.size());
  std::vector<uint8_t> active(w.residuals.size());
  size_t wrong = 0;
  for (size_t i = 0; i < active.size(); ++i) {
    const double e =
        (w.residuals[i].measurement.head<2>() - clean.residuals[i].measurement.head<2>()).norm();
    active[i] = e < 5.0;
    wrong += !active[i];
  }
  ASSERT_GT(wrong, w.residuals.size() / 20);
  std::vector<std::array<double, 7>> start_poses, with_active, with_all;
  std::vector<Eigen::Vector3d> start_points, points_active, points_all;
  Perturb(w, 8, &start_poses, &start_points);
  with_active = with_all = start_poses;
  points_active = points_all = start_points;
  SolveBundleProblem(w.residuals, active.data(), kModel, 0, 0, Iterations(30), w.fixed,
                     &with_active, &points_active);
  SolveBundleProblem(w.residuals, nullptr, kModel, 0, 0, Iterations(30), w.fixed, &with_all,
                     &points_all);
  EXPECT_LT(MaxPoseError(w, with_active), 0.01);
  EXPECT_LT(MaxPoseError(w, with_active), 0.5 * MaxPoseError(w, with_all));
}

// The pose prior (1 cm, 0.2 deg) on a window whose points fix every pose: nothing to hold, the
// same solution as without it.
TEST(BundleSolver, APosePriorLeavesPosesThePointsFix) {
  BundleSolverOptions with_prior = Iterations(30);
  with_prior.prior_sigma_translation = 0.01;
  with_prior.prior_sigma_rotation = 0.2 * M_PI / 180.0;
  for (uint32_t seed : {3u, 4u}) {
    const Window w = MakeWindow(10, 500, 2, 1.0, 0.0, seed);
    std::vector<std::array<double, 7>> start_poses, poses_prior, poses_free;
    std::vector<Eigen::Vector3d> start_points, points_prior, points_free;
    Perturb(w, seed + 20, &start_poses, &start_points);
    poses_prior = poses_free = start_poses;
    points_prior = points_free = start_points;
    SolveBundleProblem(w.residuals, nullptr, kModel, 0, 0, with_prior, w.fixed, &poses_prior,
                       &points_prior);
    SolveBundleProblem(w.residuals, nullptr, kModel, 0, 0, Iterations(30), w.fixed, &poses_free,
                       &points_free);
    for (size_t k = 0; k < poses_prior.size(); ++k) {
      const Rigid3d a = PoseFromParameters(poses_prior[k].data());
      const Rigid3d b = PoseFromParameters(poses_free[k].data());
      EXPECT_LT((a.translation - b.translation).norm(), 1e-3) << "seed " << seed << " pose " << k;
    }
  }
}

// A camera whose points lie in a narrow strip at one depth (monocular, as far points are): yaw
// and sideways translation explain the same image motion, and the noise of its observations moves
// it along that direction without the prior. With the prior it stays near where it started (the
// truth here, as tracking would give it).
TEST(BundleSolver, APosePriorHoldsAPoseAlongWhatItsPointsLeaveFree) {
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0, 1.0);
  std::uniform_real_distribution<double> strip_u(0, 50), any_v(0, 480), depth(2.0, 2.1);
  const Rigid3d first;  // cam_from_world, fixed
  const Rigid3d second =
      Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.02, Eigen::Vector3d::UnitY())),
              Eigen::Vector3d(-0.1, 0.0, 0.0));
  std::vector<Eigen::Vector3d> truth_points;
  std::vector<BundleResidual> residuals;
  for (int p = 0; p < 150; ++p) {
    // A point of the strip in the second camera, seen by the first one as well.
    const double z = depth(rng), u = strip_u(rng), v = any_v(rng);
    const Eigen::Vector3d in_second((u - kModel.cx) * z / kModel.fx,
                                    (v - kModel.cy) * z / kModel.fy, z);
    const Eigen::Vector3d world = second.Inverse() * in_second;
    truth_points.push_back(world);
    for (int k = 0; k < 2; ++k) {
      const Eigen::Vector3d c = (k == 0 ? first : second) * world;
      BundleResidual r;
      r.pose = k;
      r.point = p;
      r.measurement = Eigen::Vector3d(kModel.fx * c.x() / c.z() + kModel.cx + noise(rng),
                                      kModel.fy * c.y() / c.z() + kModel.cy + noise(rng), 0);
      residuals.push_back(r);
    }
  }
  const std::vector<uint8_t> fixed = {1, 0};
  auto solve = [&](const BundleSolverOptions& options) {
    std::vector<std::array<double, 7>> poses(2);
    PoseToParameters(first, poses[0].data());
    PoseToParameters(second, poses[1].data());
    std::vector<Eigen::Vector3d> points = truth_points;
    SolveBundleProblem(residuals, nullptr, kModel, 0, 0, options, fixed, &poses, &points);
    return (PoseFromParameters(poses[1].data()).Inverse().translation -
            second.Inverse().translation)
        .norm();
  };
  BundleSolverOptions with_prior = Iterations(30);
  with_prior.prior_sigma_translation = 0.01;
  with_prior.prior_sigma_rotation = 0.2 * M_PI / 180.0;
  const double moved_free = solve(Iterations(30)), moved_held = solve(with_prior);
  std::cout << "camera centre moved " << moved_free << " m without the prior, " << moved_held
            << " m with it\n";
  EXPECT_LT(moved_held, 0.5 * moved_free);
}

// The prior's error is the tangent of the left update: moving a pose by a small step of the
// solver (PoseManifold::Plus) from the prior's value gives that step as the error.
TEST(BundleSolver, PosePriorErrorIsTheStepFromThePrior) {
  const Rigid3d prior(
      Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized())),
      Eigen::Vector3d(0.5, -1.0, 2.0));
  std::array<double, 7> x{}, moved{};
  PoseToParameters(prior, x.data());
  Eigen::Matrix<double, 6, 1> step;
  step << 0.01, -0.02, 0.005, 0.002, -0.001, 0.003;
  PoseManifold().Plus(x.data(), step.data(), moved.data());
  const Eigen::Matrix<double, 6, 1> e = PosePriorError(PoseFromParameters(moved.data()), prior);
  EXPECT_LT((e - step).norm(), 1e-9) << e.transpose();
  EXPECT_LT(PosePriorError(prior, prior).norm(), 1e-12);
}

TEST(BundleSolver, AbortStopsBeforeTheFirstStep) {
  const Window w = MakeWindow(6, 200, 1, 0.5, 0.0, 9);
  std::vector<std::array<double, 7>> poses;
  std::vector<Eigen::Vector3d> points;
  Perturb(w, 10, &poses, &points);
  const auto before = poses;
  std::atomic<bool> abort{true};
  const BundleSolverSummary s = SolveBundleProblem(
      w.residuals, nullptr, kModel, 0, 0, BundleSolverOptions{}, w.fixed, &poses, &points, &abort);
  EXPECT_TRUE(s.aborted);
  EXPECT_EQ(s.iterations, 0);
  for (size_t k = 0; k < poses.size(); ++k)
    for (int i = 0; i < 7; ++i) EXPECT_NEAR(poses[k][i], before[k][i], 1e-12);
}

TEST(BundleSolver, MismatchedFixedFlagsAreRefused) {
  const Window w = MakeWindow(4, 50, 1, 0.0, 0.0, 11);
  std::vector<std::array<double, 7>> poses;
  std::vector<Eigen::Vector3d> points;
  Perturb(w, 12, &poses, &points);
  std::vector<uint8_t> fixed = w.fixed;
  fixed.pop_back();
  EXPECT_THROW(SolveBundleProblem(w.residuals, nullptr, kModel, 0, 0, BundleSolverOptions{}, fixed,
                                  &poses, &points),
               std::invalid_argument);
}

}  // namespace
}  // namespace dygslam
