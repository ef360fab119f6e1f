#include "core/slam/loop_closing/global_bundle_adjustment.h"

#include <ceres/ceres.h>

#include <array>
#include <map>

#include "core/slam/optimize/cost_functions.h"

namespace dygslam {

namespace {

// The whole map as one problem, copied under the map lock.
struct GlobalProblem {
  struct Observation {
    int64_t kf_id, point_id;
    Eigen::Vector3d measurement;
    double sqrt_info;
    bool stereo;
  };
  std::map<int64_t, std::array<double, 7>> poses;
  std::map<int64_t, Rigid3d> before;
  std::map<int64_t, Eigen::Vector3d> points;
  std::vector<Observation> observations;
  ProjectionModel model{};
  int64_t first_kf = -1;
};

// False when the map was corrected since `epoch` or holds no keyframe.
bool CollectGlobalProblem(Map& map, int64_t epoch, GlobalProblem* problem) {
  std::lock_guard<std::mutex> lock(map.mutex());
  if (map.CorrectionEpoch() != epoch || map.keyframes().empty()) return false;
  problem->first_kf = map.keyframes().begin()->first;
  const auto& g = *map.keyframes().begin()->second->geometry;
  problem->model = {g.camera.fx, g.camera.fy, g.camera.cx, g.camera.cy, g.bf};
  for (const auto& [id, k] : map.keyframes()) {
    PoseToParameters(k->cam_from_world, problem->poses[id].data());
    problem->before[id] = k->cam_from_world;
  }
  for (const auto& [pid, mp] : map.map_points()) {
    if (mp->bad || mp->NumObservations() < 2) continue;
    problem->points[pid] = mp->position;
    for (const auto& [kid, idx] : mp->observations) {
      auto k = map.GetKeyFrame(kid);
      if (!k) continue;
      const cv::KeyPoint& kp = k->undistorted[idx];
      const bool stereo = k->u_right[idx] >= 0;
      problem->observations.push_back(
          {kid, pid, Eigen::Vector3d(kp.pt.x, kp.pt.y, stereo ? k->u_right[idx] : 0.0),
           std::sqrt(k->geometry->inv_sigma2[kp.octave]), stereo});
    }
  }
  return true;
}

// Solves in place; false when aborted or failed.
bool SolveGlobalProblem(GlobalProblem* gp, const OptimizerOptions& optimizer, int iterations,
                        const std::atomic<bool>& abort_flag) {
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  PoseManifold manifold;
  const double delta_mono = std::sqrt(optimizer.chi2_mono),
               delta_stereo = std::sqrt(optimizer.chi2_stereo);
  for (const GlobalProblem::Observation& o : gp->observations) {
    ceres::CostFunction* cost =
        o.stereo ? static_cast<ceres::CostFunction*>(
                       new StereoBACost(o.measurement, o.sqrt_info, gp->model))
                 : new MonoBACost(o.measurement.head<2>(), o.sqrt_info, gp->model);
    problem.AddResidualBlock(cost, new ceres::HuberLoss(o.stereo ? delta_stereo : delta_mono),
                             gp->poses[o.kf_id].data(), gp->points[o.point_id].data());
  }
  for (auto& [id, pose] : gp->poses) {
    if (!problem.HasParameterBlock(pose.data())) continue;
    problem.SetManifold(pose.data(), &manifold);
    if (id == gp->first_kf) problem.SetParameterBlockConstant(pose.data());
  }
  struct Abort : ceres::IterationCallback {
    explicit Abort(const std::atomic<bool>* flag) : flag(flag) {}
    ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
      return flag->load() ? ceres::SOLVER_ABORT : ceres::SOLVER_CONTINUE;
    }
    const std::atomic<bool>* flag;
  } abort(&abort_flag);
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::SPARSE_SCHUR;
  solver_options.max_num_iterations = iterations;
  solver_options.num_threads = 1;
  solver_options.logging_type = ceres::SILENT;
  solver_options.callbacks.push_back(&abort);
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);
  return !(abort_flag.load() || summary.termination_type == ceres::USER_FAILURE ||
           summary.termination_type == ceres::FAILURE);
}

// Keyframes in the problem take its poses; newer ones follow their parent (chain) by the same
// world correction. Returns the new pose of every keyframe that has one. Map lock held.
std::map<int64_t, Rigid3d> CorrectedKeyFramePoses(const Map& map, const GlobalProblem& gp) {
  std::map<int64_t, Rigid3d> after;
  for (const auto& [id, p] : gp.poses) after[id] = PoseFromParameters(p.data());
  for (const auto& [id, k] : map.keyframes()) {
    if (after.count(id)) continue;
    // The anchor is a keyframe of the problem (in `before`): keyframes added to `after` by this
    // loop were not solved and have no `before` pose.
    int64_t anchor = k->parent_id;
    for (int guard = 0; guard < 1000 && anchor >= 0 && !gp.before.count(anchor); ++guard) {
      auto parent = map.GetKeyFrame(anchor);
      anchor = parent ? parent->parent_id : -1;
    }
    if (anchor < 0 || !gp.before.count(anchor)) continue;
    after[id] = k->cam_from_world * gp.before.at(anchor).Inverse() * after.at(anchor);
  }
  return after;
}

// Writes the solution back; points not in the problem follow their reference keyframe. False
// when the map was corrected since `epoch`.
bool WriteBackGlobalProblem(Map& map, int64_t epoch, const GlobalProblem& gp,
                            std::vector<int64_t>* moved) {
  std::lock_guard<std::mutex> lock(map.mutex());
  if (map.CorrectionEpoch() != epoch) return false;
  std::map<int64_t, Rigid3d> old_pose;
  for (const auto& [id, k] : map.keyframes()) old_pose[id] = k->cam_from_world;
  const std::map<int64_t, Rigid3d> after = CorrectedKeyFramePoses(map, gp);
  for (const auto& [pid, mp] : map.map_points()) {
    if (mp->bad) continue;
    auto solved = gp.points.find(pid);
    if (solved != gp.points.end()) {
      mp->position = solved->second;
    } else {
      auto ref = after.find(mp->ref_kf_id);
      auto old = old_pose.find(mp->ref_kf_id);
      if (ref == after.end() || old == old_pose.end()) continue;
      mp->position = ref->second.Inverse() * (old->second * mp->position);
    }
  }
  for (const auto& [id, k] : map.keyframes()) {
    auto a = after.find(id);
    if (a == after.end()) continue;
    k->cam_from_world = a->second;
    moved->push_back(id);
  }
  for (const auto& [pid, mp] : map.map_points())
    if (!mp->bad) map.UpdateNormalAndDepth(*mp);
  map.BumpCorrectionEpoch();
  return true;
}

}  // namespace

GlobalBundleAdjustmentResult RunGlobalBundleAdjustment(
    Map& map, int64_t epoch, const OptimizerOptions& optimizer, int iterations,
    const std::atomic<bool>& abort,
    const std::function<void(std::chrono::steady_clock::time_point)>& on_solve) {
  using Outcome = GlobalBundleAdjustmentResult::Outcome;
  GlobalBundleAdjustmentResult result;
  const auto start = std::chrono::steady_clock::now();
  GlobalProblem problem;
  if (!CollectGlobalProblem(map, epoch, &problem) || problem.observations.empty()) return result;
  result.keyframes = problem.poses.size();
  result.points = problem.points.size();
  result.observations = problem.observations.size();
  if (on_solve) on_solve(start);
  result.outcome = SolveGlobalProblem(&problem, optimizer, iterations, abort) &&
                           WriteBackGlobalProblem(map, epoch, problem, &result.moved)
                       ? Outcome::kWritten
                       : Outcome::kDiscarded;
  return result;
}

}  // namespace dygslam
