// The dedicated pose solver on generated observations, against Ceres on the same problem.
#include "core/slam/optimize/pose_solver.h"

#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/base/error.h"

namespace dygslam {
namespace {

const ProjectionModel kModel{525.0, 525.0, 319.5, 239.5, 40.0};

// Points 1.5-5 m in front of `truth`, observed with pixel noise; half stereo; a share replaced
// by a random pixel (a wrong match). is_wrong marks those.
std::vector<PoseObservation> MakeObservations(const Rigid3d& truth, int count, double noise_px,
                                              double wrong_share, uint32_t seed,
                                              std::vector<uint8_t>* is_wrong) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> x(-1.5, 1.5), y(-1.0, 1.0), z(1.5, 5.0), u01(0, 1);
  std::uniform_real_distribution<double> upix(0, 640), vpix(0, 480);
  std::normal_distribution<double> noise(0, noise_px);
  const Rigid3d world_from_cam = truth.Inverse();
  std::vector<PoseObservation> out;
  is_wrong->clear();
  for (int i = 0; i < count; ++i) {
    const Eigen::Vector3d p_cam(x(rng), y(rng), z(rng));
    const double u = kModel.fx * p_cam.x() / p_cam.z() + kModel.cx;
    const double v = kModel.fy * p_cam.y() / p_cam.z() + kModel.cy;
    PoseObservation o;
    o.point = world_from_cam * p_cam;
    o.stereo = i % 2 == 0;
    o.information = 1.0 / std::pow(1.2, 2 * (i % 4));  // octaves 0-3
    const bool wrong = u01(rng) < wrong_share;
    const double mu = wrong ? upix(rng) : u + noise(rng), mv = wrong ? vpix(rng) : v + noise(rng);
    o.measurement =
        Eigen::Vector3d(mu, mv, mu - kModel.bf / p_cam.z() + (wrong ? 0.0 : noise(rng)));
    out.push_back(o);
    is_wrong->push_back(wrong);
  }
  return out;
}

Rigid3d Perturbed(const Rigid3d& truth) {
  return Rigid3d(Eigen::Quaterniond(
                     Eigen::AngleAxisd(0.04, Eigen::Vector3d(0.2, 1, -0.3).normalized())),
                 Eigen::Vector3d(0.06, -0.03, 0.04)) *
         truth;
}

const Rigid3d kTruth(Eigen::Quaterniond(Eigen::AngleAxisd(0.3,
                                                          Eigen::Vector3d(1, 2, 0.5).normalized())),
                     Eigen::Vector3d(0.4, -0.2, 1.1));

// The same problem with Ceres (the cost functions tracking used before), returning its pose.
Rigid3d SolveWithCeres(const std::vector<PoseObservation>& obs, const Rigid3d& start, bool robust,
                       int iterations, double tolerance, double* final_cost) {
  double pose[7];
  PoseToParameters(start, pose);
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  PoseManifold manifold;
  problem.AddParameterBlock(pose, 7, &manifold);
  for (const PoseObservation& o : obs) {
    const double sqrt_info = std::sqrt(o.information);
    ceres::CostFunction* cost =
        o.stereo ? static_cast<ceres::CostFunction*>(
                       new StereoPoseCost(o.measurement, o.point, sqrt_info, kModel))
                 : new MonoPoseCost(o.measurement.head<2>(), o.point, sqrt_info, kModel);
    problem.AddResidualBlock(
        cost, robust ? new ceres::HuberLoss(std::sqrt(o.stereo ? 7.815 : 5.991)) : nullptr, pose);
  }
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_QR;
  options.max_num_iterations = iterations;
  options.function_tolerance = tolerance;
  options.parameter_tolerance = tolerance;
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  *final_cost = summary.final_cost;
  return PoseFromParameters(pose);
}

double TranslationError(const Rigid3d& a, const Rigid3d& b) {
  return (a.translation - b.translation).norm();
}
double RotationError(const Rigid3d& a, const Rigid3d& b) {
  return RotationAngle(a.rotation * b.rotation.conjugate());
}

TEST(PoseSolver, ExactObservationsGiveTheTruePose) {
  std::vector<uint8_t> wrong;
  const auto obs = MakeObservations(kTruth, 200, 0.0, 0.0, 1, &wrong);
  Rigid3d pose = Perturbed(kTruth);
  ASSERT_GT(TranslationError(pose, kTruth), 0.05);
  const PoseSolverSummary s = SolvePose(obs, nullptr, kModel, 0, 0, PoseSolverOptions{}, &pose);
  // Stopped by the function tolerance (1e-6 relative): measured 3e-9 m, cost 8e-12.
  EXPECT_LT(TranslationError(pose, kTruth), 1e-7);
  EXPECT_LT(RotationError(pose, kTruth), 1e-7);
  EXPECT_LT(s.final_cost, 1e-9);
  EXPECT_GT(s.initial_cost, 1e3);
  EXPECT_LE(s.iterations, 10);
}

TEST(PoseSolver, InactiveObservationsAreIgnored) {
  // Every other observation is a wrong match, switched off: the pose is exact again.
  std::vector<uint8_t> wrong;
  auto obs = MakeObservations(kTruth, 200, 0.0, 0.0, 2, &wrong);
  std::vector<uint8_t> active(obs.size(), 1);
  for (size_t i = 0; i < obs.size(); i += 2) {
    obs[i].measurement += Eigen::Vector3d(30, -20, 30);
    active[i] = 0;
  }
  Rigid3d pose = Perturbed(kTruth);
  SolvePose(obs, active.data(), kModel, 0, 0, PoseSolverOptions{}, &pose);
  EXPECT_LT(TranslationError(pose, kTruth), 1e-7);
  Rigid3d all = Perturbed(kTruth);
  SolvePose(obs, nullptr, kModel, 0, 0, PoseSolverOptions{}, &all);
  EXPECT_GT(TranslationError(all, kTruth), 1e-3);  // the shifted ones do pull when active
}

// Noise and 25 % wrong matches, with and without the Huber kernel, against Ceres on the same
// problem. (a) Tracking's settings (<= 10 iterations, function tolerance 1e-6): both stop after
// 4-7 steps; the costs agree within the tolerance (measured: ours lower or equal in all 10 cases,
// at most 7e-7 relative apart) and the poses within 0.14 mm / 1.3e-5 rad with the kernel.
// (b) Without the stopping tolerances, 50 iterations: the same minimum.
TEST(PoseSolver, MatchesCeresWithAndWithoutTheKernel) {
  for (uint32_t seed = 10; seed < 15; ++seed) {
    std::vector<uint8_t> wrong;
    const auto obs = MakeObservations(kTruth, 300, 1.0, 0.25, seed, &wrong);
    for (const bool robust : {true, false}) {
      const double delta_mono = robust ? std::sqrt(5.991) : 0,
                   delta_stereo = robust ? std::sqrt(7.815) : 0;
      Rigid3d pose = Perturbed(kTruth);
      const PoseSolverSummary s =
          SolvePose(obs, nullptr, kModel, delta_mono, delta_stereo, PoseSolverOptions{}, &pose);
      double ceres_cost = 0;
      const Rigid3d reference =
          SolveWithCeres(obs, Perturbed(kTruth), robust, 10, 1e-6, &ceres_cost);
      EXPECT_LE(s.iterations, 10);
      EXPECT_LT(s.final_cost, s.initial_cost) << seed << " " << robust;
      EXPECT_LE(s.final_cost, ceres_cost * (1 + 1e-5)) << seed << " " << robust;
      EXPECT_GE(s.final_cost, ceres_cost * (1 - 1e-5)) << seed << " " << robust;
      if (robust) {
        EXPECT_LT(TranslationError(pose, reference), 1e-3) << seed;
        EXPECT_LT(RotationError(pose, reference), 1e-4) << seed;
        EXPECT_LT(TranslationError(pose, kTruth), 0.02)
            << seed;  // the kernel holds the wrong matches off
      }

      PoseSolverOptions exhaustive;
      exhaustive.max_iterations = 50;
      exhaustive.function_tolerance = exhaustive.parameter_tolerance = 0;
      Rigid3d converged = Perturbed(kTruth);
      SolvePose(obs, nullptr, kModel, delta_mono, delta_stereo, exhaustive, &converged);
      const Rigid3d converged_reference =
          SolveWithCeres(obs, Perturbed(kTruth), robust, 50, 0, &ceres_cost);
      EXPECT_LT(TranslationError(converged, converged_reference), 1e-7) << seed << " " << robust;
      EXPECT_LT(RotationError(converged, converged_reference), 1e-7) << seed << " " << robust;
    }
  }
}

// Observations of points in a narrow vertical strip at one depth (the static background beside
// a person filling the view), monocular, with pixel noise: sideways translation and yaw explain
// nearly the same image motion there.
std::vector<PoseObservation> StripObservations(const Rigid3d& truth, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> x(0.9, 1.1), y(-1.0, 1.0), z(2.95, 3.05);
  std::normal_distribution<double> noise(0, 1.0);
  const Rigid3d world_from_cam = truth.Inverse();
  std::vector<PoseObservation> out;
  for (int i = 0; i < 40; ++i) {
    const Eigen::Vector3d p_cam(x(rng), y(rng), z(rng));
    PoseObservation o;
    o.point = world_from_cam * p_cam;
    o.measurement = Eigen::Vector3d(kModel.fx * p_cam.x() / p_cam.z() + kModel.cx + noise(rng),
                                    kModel.fy * p_cam.y() / p_cam.z() + kModel.cy + noise(rng), 0);
    out.push_back(o);
  }
  return out;
}

// The motion prior of tracking (1 cm, 3 deg): none where the observations fix every direction,
// and where they leave one nearly free (a strip), the pose stays near the prediction along it.
TEST(PoseSolver, MotionPriorActsOnlyInTheDirectionsTheObservationsLeaveFree) {
  const double sigma_t = 0.01, sigma_r = 3.0 * M_PI / 180.0;
  std::vector<uint8_t> wrong;
  const auto wide = MakeObservations(kTruth, 200, 1.0, 0.0, 3, &wrong);
  const Eigen::Matrix<double, 6, 6> wide_prior =
      PriorInWeakDirections(PoseInformation(wide, nullptr, kModel, 0, 0, kTruth), sigma_t, sigma_r);
  EXPECT_EQ(wide_prior.norm(), 0.0);  // every direction fixed by the points

  // The prediction is 5 mm / 0.2 deg off the truth (a motion model's error).
  const Rigid3d predicted =
      Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.0035, Eigen::Vector3d::UnitY())),
              Eigen::Vector3d(0.005, 0, 0)) *
      kTruth;
  double error_without = 0, error_with = 0;
  for (uint32_t seed = 20; seed < 30; ++seed) {
    const auto strip = StripObservations(kTruth, seed);
    PosePrior prior{predicted};
    prior.information = PriorInWeakDirections(
        PoseInformation(strip, nullptr, kModel, 0, 0, predicted), sigma_t, sigma_r);
    EXPECT_GT(prior.information.norm(), 0.0) << seed;
    Rigid3d without = predicted, with = predicted;
    SolvePose(strip, nullptr, kModel, 0, 0, PoseSolverOptions{}, &without);
    SolvePose(strip, nullptr, kModel, 0, 0, PoseSolverOptions{}, &with, &prior);
    error_without += TranslationError(without, kTruth);
    error_with += TranslationError(with, kTruth);
  }
  // Measured: mean 3.7 cm without the prior, 0.55 cm with it (the prediction is 0.5 cm off).
  EXPECT_LT(error_with, 0.5 * error_without);
}

TEST(PoseSolver, OptionsCheckNamesTheField) {
  PoseSolverOptions options;
  options.max_iterations = 0;
  try {
    options.Check();
    FAIL() << "no error for max_iterations 0";
  } catch (const InvalidOptions& e) {
    EXPECT_NE(std::string(e.what()).find("Optimizer.pose_iterations"), std::string::npos)
        << e.what();
  }
  EXPECT_NO_THROW(PoseSolverOptions{}.Check());
}

}  // namespace
}  // namespace dygslam
