#include "core/slam/optimize/optimizer.h"

#include <ceres/ceres.h>

#include <array>
#include <cmath>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>

#include "core/slam/optimize/bundle_solver.h"
#include "core/slam/optimize/cost_functions.h"
#include "core/slam/optimize/pose_solver.h"

namespace dygslam {
namespace {

// Bundle adjustments with at most this many keyframe poses solve with a dense Schur complement.
constexpr size_t kDenseSchurMaxPoses = 100;
// ... and with at most this many variable poses, with the dedicated solver (its reduced camera
// system is a dense matrix of 6 x this size).
constexpr size_t kDedicatedSolverMaxPoses = 60;

ProjectionModel ModelOf(const CameraGeometry& g) {
  return {g.camera.fx, g.camera.fy, g.camera.cx, g.camera.cy, g.bf};
}

class AbortCallback : public ceres::IterationCallback {
 public:
  explicit AbortCallback(const std::atomic<bool>* abort) : abort_(abort) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
    return (abort_ && abort_->load()) ? ceres::SOLVER_TERMINATE_SUCCESSFULLY
                                      : ceres::SOLVER_CONTINUE;
  }

 private:
  const std::atomic<bool>* abort_;
};

}  // namespace

namespace {

// The frame's matched map points as pose residuals (clears frame.outlier for them); `index` gets
// each observation's keypoint index.
void CollectPoseObservations(Frame& frame, std::vector<PoseObservation>* observations,
                             std::vector<size_t>* index) {
  const CameraGeometry& g = *frame.geometry;
  observations->clear();
  index->clear();
  for (size_t i = 0; i < frame.size(); ++i) {
    const auto& mp = frame.map_points[i];
    if (!mp) continue;
    frame.outlier[i] = 0;
    const cv::KeyPoint& kp = frame.undistorted[i];
    const bool stereo = frame.u_right[i] >= 0;
    observations->push_back({mp->position,
                             Eigen::Vector3d(kp.pt.x, kp.pt.y, stereo ? frame.u_right[i] : 0.0),
                             g.inv_sigma2[kp.octave], stereo});
    index->push_back(i);
  }
}

// Marks every observation (including earlier outliers) by its chi2 at cam_from_world (behind the
// camera: outlier); writes frame.outlier and returns the inliers.
int ClassifyPoseObservations(const std::vector<PoseObservation>& observations,
                             const std::vector<size_t>& index, const Rigid3d& cam_from_world,
                             const ProjectionModel& model, const OptimizerOptions& options,
                             Frame& frame) {
  int inliers = 0;
  for (size_t k = 0; k < observations.size(); ++k) {
    const PoseObservation& o = observations[k];
    const Eigen::Vector3d p = cam_from_world * o.point;
    double chi2 = 0;
    const bool bad_depth = p.z() <= 0;
    if (!bad_depth) {
      const double u = model.fx * p.x() / p.z() + model.cx, v = model.fy * p.y() / p.z() + model.cy;
      chi2 = (u - o.measurement.x()) * (u - o.measurement.x()) +
             (v - o.measurement.y()) * (v - o.measurement.y());
      if (o.stereo) {
        const double ur = u - model.bf / p.z();
        chi2 += (ur - o.measurement.z()) * (ur - o.measurement.z());
      }
      chi2 *= o.information;
    }
    const bool is_outlier =
        bad_depth || chi2 > (o.stereo ? options.chi2_stereo : options.chi2_mono);
    frame.outlier[index[k]] = is_outlier ? 1 : 0;
    if (!is_outlier) ++inliers;
  }
  return inliers;
}

}  // namespace

int OptimizePose(Frame& frame, const OptimizerOptions& options) {
  // Reused across calls of one thread: no allocation per frame once warm.
  thread_local std::vector<PoseObservation> observations;
  thread_local std::vector<size_t> index;
  thread_local std::vector<uint8_t> active;
  CollectPoseObservations(frame, &observations, &index);
  if (observations.size() < 3) return 0;
  const ProjectionModel model = ModelOf(*frame.geometry);
  const double delta_mono = std::sqrt(options.chi2_mono),
               delta_stereo = std::sqrt(options.chi2_stereo);
  PoseSolverOptions solver_options;
  solver_options.max_iterations = options.pose_iterations;
  Rigid3d cam_from_world = frame.cam_from_world;
  const bool use_prior = options.pose_motion_prior && frame.motion_prior.has_value();
  active.assign(observations.size(), 1);
  int inliers = 0;
  for (int round = 0; round < options.pose_rounds; ++round) {
    const bool robust = round < options.pose_rounds - 1;  // last round without the kernel
    int added = 0;
    for (size_t k = 0; k < index.size(); ++k) {
      active[k] = frame.outlier[index[k]] ? 0 : 1;
      added += active[k];
    }
    if (added < 3) break;
    const double delta_m = robust ? delta_mono : 0.0, delta_s = robust ? delta_stereo : 0.0;
    std::optional<PosePrior> prior;
    if (use_prior) {
      prior = PosePrior{*frame.motion_prior};
      prior->information = PriorInWeakDirections(
          PoseInformation(observations, active.data(), model, delta_m, delta_s, cam_from_world),
          options.pose_prior_sigma_translation,
          options.pose_prior_sigma_rotation_deg * M_PI / 180.0);
    }
    SolvePose(observations, active.data(), model, delta_m, delta_s, solver_options, &cam_from_world,
              prior ? &*prior : nullptr);
    inliers = ClassifyPoseObservations(observations, index, cam_from_world, model, options, frame);
    if (inliers < 10) break;
  }
  frame.cam_from_world = cam_from_world;
  return inliers;
}

namespace {

// The keyframes of the local window around `kf`: it and its covisible keyframes (empty when kf
// was culled). Called under the map lock.
std::vector<std::shared_ptr<KeyFrame>> LocalWindow(const Map& map,
                                                   const std::shared_ptr<KeyFrame>& kf) {
  std::vector<std::shared_ptr<KeyFrame>> local;
  if (kf->bad) return local;
  local.push_back(kf);
  for (int64_t id : kf->ordered_connections) {
    auto other = map.GetKeyFrame(id);
    if (other && !other->bad) local.push_back(other);
  }
  return local;
}

}  // namespace

// Copies the problem of the keyframes `local` (with every point they see; other keyframes
// observing those points are fixed, and so is the map's first keyframe, else the oldest selected
// one, when nothing else fixes the gauge). Called under the map lock.
BundleProblem PrepareBundle(const Map& map, const std::vector<std::shared_ptr<KeyFrame>>& local) {
  BundleProblem problem;
  if (local.empty()) return problem;
  problem.epoch = map.CorrectionEpoch();
  const CameraGeometry& g = *local.front()->geometry;
  problem.model = ModelOf(g);
  for (const auto& k : local) PoseToParameters(k->cam_from_world, problem.poses[k->id].data());
  std::map<int64_t, std::shared_ptr<MapPoint>> local_points;
  for (const auto& k : local) {
    for (const auto& mp : k->map_points) {
      if (mp && !mp->bad) local_points[mp->id] = mp;
    }
  }
  for (const auto& [pid, mp] : local_points) {
    problem.points[pid] = mp->position;
    for (const auto& [obs_kf_id, idx] : mp->observations) {
      auto obs_kf = map.GetKeyFrame(obs_kf_id);
      if (!obs_kf || obs_kf->bad) continue;
      if (!problem.poses.count(obs_kf_id)) {
        PoseToParameters(obs_kf->cam_from_world, problem.poses[obs_kf_id].data());
        problem.fixed.insert(obs_kf_id);
      }
      const cv::KeyPoint& kp = obs_kf->undistorted[idx];
      const bool stereo = obs_kf->u_right[idx] >= 0;
      problem.observations.push_back(
          {obs_kf_id, pid, Eigen::Vector3d(kp.pt.x, kp.pt.y, stereo ? obs_kf->u_right[idx] : 0.0),
           std::sqrt(obs_kf->geometry->inv_sigma2[kp.octave]), stereo});
    }
  }
  // Gauge: if no keyframe outside the local window observes the points, fix the oldest one.
  if (problem.poses.count(map.keyframes().begin()->first))
    problem.fixed.insert(map.keyframes().begin()->first);
  if (problem.fixed.empty()) problem.fixed.insert(problem.poses.begin()->first);
  return problem;
}

BundleProblem PrepareLocalBundle(const Map& map, const std::shared_ptr<KeyFrame>& kf) {
  BundleProblem problem = PrepareBundle(map, LocalWindow(map, kf));
  problem.local_window = true;
  return problem;
}

namespace {

// A local window's solve: the dedicated Schur-complement solver (core/slam/optimize/
// bundle_solver.h) on the problem indexed once.
class DedicatedBundleSolve {
 public:
  DedicatedBundleSolve(BundleProblem* bundle, double prior_sigma_translation,
                       double prior_sigma_rotation)
      : bundle_(*bundle),
        prior_sigma_translation_(prior_sigma_translation),
        prior_sigma_rotation_(prior_sigma_rotation) {
    std::map<int64_t, int> pose_index, point_index;
    for (const auto& [id, pose] : bundle_.poses) {
      pose_index[id] = static_cast<int>(pose_ids_.size());
      pose_ids_.push_back(id);
      pose_values_.push_back(pose);
      pose_fixed_.push_back(bundle_.fixed.count(id) ? 1 : 0);
    }
    for (const auto& [id, point] : bundle_.points) {
      point_index[id] = static_cast<int>(point_ids_.size());
      point_ids_.push_back(id);
      point_values_.push_back(point);
    }
    residuals_.reserve(bundle_.observations.size());
    for (const BundleObservation& o : bundle_.observations)
      residuals_.push_back({pose_index.at(o.kf_id), point_index.at(o.point_id), o.measurement,
                            o.sqrt_info, o.stereo});
  }
  // The inliers (bundle->outlier 0), `iterations` at most; Huber kernels of `delta_*` (0: none).
  void Solve(int iterations, double delta_mono, double delta_stereo,
             const std::atomic<bool>* abort) {
    std::vector<uint8_t> active(bundle_.observations.size());
    for (size_t k = 0; k < active.size(); ++k) active[k] = bundle_.outlier[k] ? 0 : 1;
    BundleSolverOptions solver_options;
    solver_options.max_iterations = iterations;
    solver_options.prior_sigma_translation = prior_sigma_translation_;
    solver_options.prior_sigma_rotation = prior_sigma_rotation_;
    SolveBundleProblem(residuals_, active.data(), bundle_.model, delta_mono, delta_stereo,
                       solver_options, pose_fixed_, &pose_values_, &point_values_, abort);
    for (size_t k = 0; k < pose_ids_.size(); ++k) bundle_.poses[pose_ids_[k]] = pose_values_[k];
    for (size_t k = 0; k < point_ids_.size(); ++k) bundle_.points[point_ids_[k]] = point_values_[k];
  }

 private:
  BundleProblem& bundle_;
  double prior_sigma_translation_, prior_sigma_rotation_;
  std::vector<int64_t> pose_ids_, point_ids_;
  std::vector<std::array<double, 7>> pose_values_;
  std::vector<uint8_t> pose_fixed_;
  std::vector<Eigen::Vector3d> point_values_;
  std::vector<BundleResidual> residuals_;
};

// A large problem's solve: Ceres with a sparse camera system. Cost functions and the two Huber
// kernels are made once and shared by both solves (the problems do not own them): only the
// problem's structure is rebuilt for the second solve.
class CeresBundleSolve {
 public:
  CeresBundleSolve(BundleProblem* bundle, double delta_mono, double delta_stereo)
      : bundle_(*bundle), huber_mono_(delta_mono), huber_stereo_(delta_stereo) {
    costs_.reserve(bundle_.observations.size());
    for (const BundleObservation& o : bundle_.observations) {
      if (o.stereo) {
        costs_.emplace_back(new StereoBACost(o.measurement, o.sqrt_info, bundle_.model));
      } else {
        costs_.emplace_back(new MonoBACost(o.measurement.head<2>(), o.sqrt_info, bundle_.model));
      }
    }
  }

  void Solve(int iterations, bool robust, const std::atomic<bool>* abort) {
    ceres::Problem::Options problem_options;
    problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    problem_options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem problem(problem_options);
    PoseManifold manifold;
    for (size_t k = 0; k < bundle_.observations.size(); ++k) {
      if (bundle_.outlier[k]) continue;
      const BundleObservation& o = bundle_.observations[k];
      ceres::LossFunction* loss = robust ? (o.stereo ? &huber_stereo_ : &huber_mono_) : nullptr;
      problem.AddResidualBlock(costs_[k].get(), loss, bundle_.poses[o.kf_id].data(),
                               bundle_.points[o.point_id].data());
    }
    for (auto& [id, pose] : bundle_.poses) {
      if (!problem.HasParameterBlock(pose.data())) continue;
      problem.SetManifold(pose.data(), &manifold);
      if (bundle_.fixed.count(id)) problem.SetParameterBlockConstant(pose.data());
    }
    ceres::Solver::Options solver_options;
    // The reduced camera system of a local window is small and dense (its keyframes share most
    // points): a dense Schur complement suits it; sparse for large global problems.
    solver_options.linear_solver_type =
        bundle_.poses.size() <= kDenseSchurMaxPoses ? ceres::DENSE_SCHUR : ceres::SPARSE_SCHUR;
    solver_options.max_num_iterations = iterations;
    solver_options.num_threads = 1;
    solver_options.logging_type = ceres::SILENT;
    AbortCallback abort_callback(abort);
    if (abort) solver_options.callbacks.push_back(&abort_callback);
    ceres::Solver::Summary summary;
    ceres::Solve(solver_options, &problem, &summary);
  }

 private:
  BundleProblem& bundle_;
  std::vector<std::unique_ptr<ceres::CostFunction>> costs_;
  ceres::HuberLoss huber_mono_, huber_stereo_;
};

// Marks each observation whose reprojection error (chi2 with its information) exceeds the
// threshold of its kind, or whose point lies behind the camera, as an outlier.
void ClassifyBundleOutliers(BundleProblem* bundle, const OptimizerOptions& options) {
  const ProjectionModel& model = bundle->model;
  for (size_t k = 0; k < bundle->observations.size(); ++k) {
    const BundleObservation& o = bundle->observations[k];
    const Rigid3d cw = PoseFromParameters(bundle->poses[o.kf_id].data());
    const Eigen::Vector3d p = cw * bundle->points[o.point_id];
    if (p.z() <= 0) {
      bundle->outlier[k] = 1;
      continue;
    }
    const double u = model.fx * p.x() / p.z() + model.cx, v = model.fy * p.y() / p.z() + model.cy;
    double chi2 = (u - o.measurement.x()) * (u - o.measurement.x()) +
                  (v - o.measurement.y()) * (v - o.measurement.y());
    if (o.stereo) {
      const double ur = u - model.bf / p.z();
      chi2 += (ur - o.measurement.z()) * (ur - o.measurement.z());
    }
    chi2 *= o.sqrt_info * o.sqrt_info;
    bundle->outlier[k] = chi2 > (o.stereo ? options.chi2_stereo : options.chi2_mono) ? 1 : 0;
  }
}

}  // namespace

void SolveBundle(BundleProblem& bundle, const OptimizerOptions& options, int iterations_first,
                 int iterations_second, const std::atomic<bool>* abort) {
  bundle.outlier.assign(bundle.observations.size(), 0);
  if (bundle.observations.empty()) return;
  const double delta_mono = std::sqrt(options.chi2_mono),
               delta_stereo = std::sqrt(options.chi2_stereo);
  // Robust first, then without the kernel on the inliers.
  const auto two_passes = [&](auto&& solve) {
    solve(iterations_first, true);
    if (!(abort && abort->load())) {
      ClassifyBundleOutliers(&bundle, options);
      solve(iterations_second, false);
    }
  };
  const bool prior = bundle.local_window && options.local_ba_pose_prior;
  const double prior_translation = prior ? options.local_ba_prior_sigma_translation : 0.0;
  const double prior_rotation =
      prior ? options.local_ba_prior_sigma_rotation_deg * M_PI / 180.0 : 0.0;
  // Local windows: the dedicated solver (with the pose prior of a local window); larger problems:
  // Ceres (a local window of more than kDedicatedSolverMaxPoses keyframes has no prior).
  if (bundle.poses.size() - bundle.fixed.size() <= kDedicatedSolverMaxPoses) {
    DedicatedBundleSolve dedicated(&bundle, prior_translation, prior_rotation);
    two_passes([&](int iterations, bool robust) {
      dedicated.Solve(iterations, robust ? delta_mono : 0.0, robust ? delta_stereo : 0.0, abort);
    });
  } else {
    CeresBundleSolve general(&bundle, delta_mono, delta_stereo);
    two_passes([&](int iterations, bool robust) { general.Solve(iterations, robust, abort); });
  }
  ClassifyBundleOutliers(&bundle, options);
  bundle.solved = true;
}

bool ApplyBundle(Map& map, const BundleProblem& bundle) {
  if (!bundle.solved || bundle.observations.empty()) return false;
  // A loop correction moved the map meanwhile: this solution is relative to the old poses.
  if (map.CorrectionEpoch() != bundle.epoch) return false;
  // Drop outlier observations, then write back poses and points.
  for (size_t k = 0; k < bundle.observations.size(); ++k) {
    if (!bundle.outlier[k]) continue;
    const BundleObservation& o = bundle.observations[k];
    auto it = map.map_points().find(o.point_id);
    if (it == map.map_points().end()) continue;
    auto mp = it->second;
    map.EraseObservation(mp, o.kf_id);
  }
  for (const auto& [id, pose] : bundle.poses) {
    if (bundle.fixed.count(id)) continue;
    auto k = map.GetKeyFrame(id);
    if (k && !k->bad) k->cam_from_world = PoseFromParameters(pose.data());
  }
  for (const auto& [pid, position] : bundle.points) {
    auto it = map.map_points().find(pid);
    if (it == map.map_points().end()) continue;
    it->second->position = position;
    map.UpdateNormalAndDepth(*it->second);
  }
  return true;
}

namespace {

// Copy in under the map lock, solve without it, write back under it.
void AdjustBundle(Map& map, const std::function<BundleProblem()>& prepare,
                  const OptimizerOptions& options, int iterations_first, int iterations_second,
                  const std::atomic<bool>* abort) {
  BundleProblem bundle;
  {
    std::lock_guard<std::mutex> lock(map.mutex());
    bundle = prepare();
  }
  if (bundle.observations.empty()) return;
  SolveBundle(bundle, options, iterations_first, iterations_second, abort);
  std::lock_guard<std::mutex> lock(map.mutex());
  ApplyBundle(map, bundle);
}

}  // namespace

void LocalBundleAdjustment(Map& map, const std::shared_ptr<KeyFrame>& kf,
                           const OptimizerOptions& options, const std::atomic<bool>* abort) {
  AdjustBundle(
      map, [&map, &kf]() { return PrepareLocalBundle(map, kf); }, options,
      options.ba_iterations_first, options.ba_iterations_second, abort);
}

void GlobalBundleAdjustment(Map& map, const OptimizerOptions& options, int iterations_first,
                            int iterations_second) {
  auto prepare = [&map]() {
    std::vector<std::shared_ptr<KeyFrame>> all;
    for (const auto& [id, k] : map.keyframes())
      if (!k->bad) all.push_back(k);
    return PrepareBundle(map, all);
  };
  AdjustBundle(map, prepare, options, iterations_first, iterations_second, nullptr);
}

}  // namespace dygslam
