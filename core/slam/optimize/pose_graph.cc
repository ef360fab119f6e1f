#include "core/slam/optimize/pose_graph.h"

#include <ceres/ceres.h>

#include <array>

#include "core/slam/optimize/cost_functions.h"

namespace dygslam {
namespace {

// Residual of one edge: the error E = measured^-1 * (T_i * T_j^-1) as [t_E, 2 vec(q_E)], scaled.
// Parameter blocks per pose: t (3) and q (4, Eigen order x y z w, EigenQuaternionManifold) of
// cam_from_world.
struct RelativePoseError {
  RelativePoseError(const Rigid3d& i_from_j, double weight)
      : measured_inverse(i_from_j.Inverse()), weight(weight) {}

  template <typename T>
  bool operator()(const T* t_i, const T* q_i, const T* t_j, const T* q_j, T* residual) const {
    const Eigen::Matrix<T, 3, 1> ti(t_i[0], t_i[1], t_i[2]);
    const Eigen::Quaternion<T> qi(q_i[3], q_i[0], q_i[1], q_i[2]);
    const Eigen::Matrix<T, 3, 1> tj(t_j[0], t_j[1], t_j[2]);
    const Eigen::Quaternion<T> qj(q_j[3], q_j[0], q_j[1], q_j[2]);
    // T_i * T_j^-1: rotation qi * qj^-1, translation ti - (qi qj^-1) tj.
    const Eigen::Quaternion<T> qij = qi * qj.conjugate();
    const Eigen::Matrix<T, 3, 1> tij = ti - qij * tj;
    const Eigen::Quaternion<T> qm = measured_inverse.rotation.cast<T>();
    const Eigen::Matrix<T, 3, 1> tm = measured_inverse.translation.cast<T>();
    Eigen::Quaternion<T> qe = qm * qij;
    const Eigen::Matrix<T, 3, 1> te = qm * tij + tm;
    if (qe.w() < T(0)) qe.coeffs() = -qe.coeffs();
    for (int k = 0; k < 3; ++k) {
      residual[k] = T(weight) * te[k];
      residual[3 + k] = T(2.0 * weight) * qe.vec()[k];
    }
    return true;
  }

  Rigid3d measured_inverse;
  double weight;
};

}  // namespace

PoseGraphSummary OptimizePoseGraph(std::map<int64_t, Rigid3d>* cam_from_world,
                                   const std::vector<PoseGraphEdge>& edges,
                                   const std::set<int64_t>& fixed, int max_iterations) {
  PoseGraphSummary summary_out;
  std::map<int64_t, std::array<double, 7>> params;
  for (const auto& [id, pose] : *cam_from_world) PoseToParameters(pose, params[id].data());
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  ceres::EigenQuaternionManifold manifold;
  int added = 0;
  for (const PoseGraphEdge& e : edges) {
    auto a = params.find(e.i), b = params.find(e.j);
    if (a == params.end() || b == params.end() || e.i == e.j) continue;
    auto* cost = new ceres::AutoDiffCostFunction<RelativePoseError, 6, 3, 4, 3, 4>(
        new RelativePoseError(e.i_from_j, e.weight));
    problem.AddResidualBlock(cost, nullptr, a->second.data(), a->second.data() + 3,
                             b->second.data(), b->second.data() + 3);
    ++added;
  }
  if (added == 0) return summary_out;
  for (auto& [id, p] : params) {
    if (!problem.HasParameterBlock(p.data())) continue;
    problem.SetManifold(p.data() + 3, &manifold);
    if (fixed.count(id)) {
      problem.SetParameterBlockConstant(p.data());
      problem.SetParameterBlockConstant(p.data() + 3);
    }
  }
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  options.max_num_iterations = max_iterations;
  options.num_threads = 1;
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  summary_out.initial_cost = summary.initial_cost;
  summary_out.final_cost = summary.final_cost;
  summary_out.iterations = static_cast<int>(summary.iterations.size());
  for (auto& [id, pose] : *cam_from_world) pose = PoseFromParameters(params[id].data());
  return summary_out;
}

}  // namespace dygslam
