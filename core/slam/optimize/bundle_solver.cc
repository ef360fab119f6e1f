#include "core/slam/optimize/bundle_solver.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

#include "core/base/error.h"
#include "core/slam/optimize/cost_functions.h"

namespace dygslam {
namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix63d = Eigen::Matrix<double, 6, 3>;

// Huber on the squared norm s: rho(s) and its derivative rho'(s) (the IRLS weight).
inline void Huber(double s, double delta, double* rho, double* weight) {
  if (delta <= 0 || s <= delta * delta) {
    *rho = s;
    *weight = 1.0;
    return;
  }
  const double r = std::sqrt(s);
  *rho = 2.0 * delta * r - delta * delta;
  *weight = delta / r;
}

struct State {
  std::vector<Eigen::Quaterniond> rotation;  // cam_from_world per pose
  std::vector<Eigen::Vector3d> translation;
  std::vector<Eigen::Vector3d> points;
};

// The normal equations at a state, in blocks: cameras (variable poses only), points, and the
// camera-point coupling of each residual whose pose is variable.
struct Linearization {
  std::vector<Matrix6d> h_cc;
  std::vector<Vector6d> g_c;
  std::vector<Eigen::Matrix3d> h_pp;
  std::vector<Eigen::Vector3d> g_p;
  std::vector<Matrix63d> h_cp;      // per residual
  std::vector<uint8_t> point_seen;  // the point has a residual in front of its camera
  void Reset(size_t cameras, size_t points, size_t residuals) {
    h_cc.assign(cameras, Matrix6d::Zero());
    g_c.assign(cameras, Vector6d::Zero());
    h_pp.assign(points, Eigen::Matrix3d::Zero());
    g_p.assign(points, Eigen::Vector3d::Zero());
    h_cp.assign(residuals, Matrix63d::Zero());  // a residual behind its camera couples nothing
    point_seen.assign(points, 0);
  }
};

class Problem {
 public:
  Problem(const std::vector<BundleResidual>& residuals, const uint8_t* active,
          const ProjectionModel& model, double delta_mono, double delta_stereo,
          const std::vector<uint8_t>& fixed, size_t num_points)
      : residuals_(residuals), model_(model), delta_mono_(delta_mono), delta_stereo_(delta_stereo) {
    camera_of_pose_.assign(fixed.size(), -1);
    for (size_t k = 0; k < fixed.size(); ++k)
      if (!fixed[k]) camera_of_pose_[k] = num_cameras_++;
    // The active residuals grouped by point (CSR), for the Schur complement.
    std::vector<int> count(num_points + 1, 0);
    for (size_t i = 0; i < residuals.size(); ++i) {
      if (active && !active[i]) continue;
      active_.push_back(static_cast<int>(i));
      ++count[residuals[i].point + 1];
    }
    for (size_t p = 0; p < num_points; ++p) count[p + 1] += count[p];
    point_begin_ = count;
    by_point_.resize(active_.size());
    std::vector<int> next(count.begin(), count.end() - 1);
    for (int i : active_) by_point_[next[residuals[i].point]++] = i;
  }

  // A prior on each variable pose at its value in `s`, in the directions its observations leave
  // (nearly) free: the camera's block of the reduced camera system at `s` (points eliminated, the
  // other cameras held), whitened by the prior's standard deviations; its eigen-directions whose
  // information is below the prior's get the prior (BundleSolverOptions::prior_sigma_*).
  void SetPrior(const State& s, const Linearization& lin, double sigma_translation,
                double sigma_rotation) {
    if (sigma_translation <= 0 || sigma_rotation <= 0) return;
    const std::vector<Matrix6d> blocks = CameraBlocks(lin);
    prior_.clear();
    prior_information_.assign(num_cameras_, Matrix6d::Zero());
    for (size_t k = 0; k < s.rotation.size(); ++k) {
      prior_.emplace_back(s.rotation[k], s.translation[k]);
      const int c = camera_of_pose_[k];
      if (c < 0) continue;
      prior_information_[c] = PriorInWeakDirections(blocks[c], sigma_translation, sigma_rotation);
    }
  }

  // Each camera's block of the undamped reduced camera system (the points eliminated).
  std::vector<Matrix6d> CameraBlocks(const Linearization& lin) const {
    std::vector<Matrix6d> blocks(lin.h_cc.begin(), lin.h_cc.end());
    for (size_t p = 0; p < lin.h_pp.size(); ++p) {
      if (!lin.point_seen[p]) continue;
      // Pseudo-inverse: a point seen along one ray leaves its depth free, and takes the whole
      // information of that observation.
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(lin.h_pp[p]);
      const Eigen::Vector3d values = eigen.eigenvalues();
      if (!(values(2) > 0)) continue;
      Eigen::Vector3d inverse_values;
      for (int d = 0; d < 3; ++d)
        inverse_values(d) = values(d) > 1e-9 * values(2) ? 1.0 / values(d) : 0.0;
      const Eigen::Matrix3d inverse =
          eigen.eigenvectors() * inverse_values.asDiagonal() * eigen.eigenvectors().transpose();
      for (int a = point_begin_[p]; a < point_begin_[p + 1]; ++a) {
        const int i = by_point_[a];
        const int c = camera_of(residuals_[i]);
        if (c >= 0) blocks[c].noalias() -= lin.h_cp[i] * inverse * lin.h_cp[i].transpose();
      }
    }
    return blocks;
  }

  int num_cameras() const { return num_cameras_; }
  int camera_of(const BundleResidual& r) const { return camera_of_pose_[r.pose]; }

  // Cost 0.5 sum rho at `s`; with `lin`, also the normal equations.
  double Evaluate(const State& s, Linearization* lin) const {
    if (lin) lin->Reset(num_cameras_, s.points.size(), residuals_.size());
    std::vector<Eigen::Matrix3d> rotations(s.rotation.size());
    for (size_t k = 0; k < s.rotation.size(); ++k) rotations[k] = s.rotation[k].toRotationMatrix();
    double cost = 0;
    for (int i : active_) {
      const BundleResidual& r = residuals_[i];
      cost += r.stereo ? Accumulate<3>(i, r, rotations[r.pose], s, lin)
                       : Accumulate<2>(i, r, rotations[r.pose], s, lin);
    }
    for (size_t k = 0; k < prior_.size(); ++k) {
      const int c = camera_of_pose_[k];
      if (c < 0) continue;
      const Vector6d e = PosePriorError(Rigid3d(s.rotation[k], s.translation[k]), prior_[k]);
      const Vector6d information_e = prior_information_[c] * e;
      cost += 0.5 * e.dot(information_e);
      if (lin) {
        lin->h_cc[c] += prior_information_[c];
        lin->g_c[c] += information_e;
      }
    }
    return cost;
  }

  // The damped step (cameras dc, points dp) by eliminating the points; false when the reduced
  // camera system is not positive definite.
  bool Step(const Linearization& lin, double radius, std::vector<Vector6d>* dc,
            std::vector<Eigen::Vector3d>* dp) const {
    const int n = 6 * num_cameras_;
    Eigen::MatrixXd s = Eigen::MatrixXd::Zero(n, n);
    Eigen::VectorXd rhs(n);
    for (int c = 0; c < num_cameras_; ++c) {
      Matrix6d damped = lin.h_cc[c];
      for (int d = 0; d < 6; ++d) damped(d, d) += std::clamp(damped(d, d), 1e-6, 1e32) / radius;
      s.block<6, 6>(6 * c, 6 * c) = damped;
      rhs.segment<6>(6 * c) = -lin.g_c[c];
    }
    const size_t num_points = lin.h_pp.size();
    std::vector<Eigen::Matrix3d> inverse(num_points);
    std::vector<Matrix63d> w;
    for (size_t p = 0; p < num_points; ++p) {
      if (!lin.point_seen[p]) continue;
      Eigen::Matrix3d damped = lin.h_pp[p];
      for (int d = 0; d < 3; ++d) damped(d, d) += std::clamp(damped(d, d), 1e-6, 1e32) / radius;
      bool invertible = false;
      damped.computeInverseWithCheck(inverse[p], invertible, 1e-300);
      if (!invertible || !inverse[p].allFinite()) {
        inverse[p].setZero();  // the point stays where it is
        continue;
      }
      const int begin = point_begin_[p], end = point_begin_[p + 1];
      w.resize(end - begin);
      for (int a = begin; a < end; ++a) {
        const int i = by_point_[a];
        const int ci = camera_of(residuals_[i]);
        if (ci < 0) continue;
        w[a - begin] = lin.h_cp[i] * inverse[p];
        rhs.segment<6>(6 * ci).noalias() += w[a - begin] * lin.g_p[p];
        for (int b = begin; b < end; ++b) {
          const int j = by_point_[b];
          const int cj = camera_of(residuals_[j]);
          if (cj < 0 || cj < ci) continue;
          // The lower triangle only: the LDLT below reads nothing else.
          s.block<6, 6>(6 * cj, 6 * ci).noalias() -= lin.h_cp[j] * w[a - begin].transpose();
        }
      }
    }
    Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
    if (n > 0) {
      const Eigen::LDLT<Eigen::MatrixXd> ldlt(s);
      if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) return false;
      x = ldlt.solve(rhs);
      if (!x.allFinite()) return false;
    }
    dc->resize(num_cameras_);
    for (int c = 0; c < num_cameras_; ++c) (*dc)[c] = x.segment<6>(6 * c);
    dp->assign(num_points, Eigen::Vector3d::Zero());
    for (size_t p = 0; p < num_points; ++p) {
      if (!lin.point_seen[p]) continue;
      Eigen::Vector3d b = -lin.g_p[p];
      for (int a = point_begin_[p]; a < point_begin_[p + 1]; ++a) {
        const int i = by_point_[a];
        const int ci = camera_of(residuals_[i]);
        if (ci >= 0) b.noalias() -= lin.h_cp[i].transpose() * (*dc)[ci];
      }
      (*dp)[p] = inverse[p] * b;
    }
    return true;
  }

  // g' step + 0.5 step' H step with the undamped H.
  double ModelChange(const Linearization& lin, const std::vector<Vector6d>& dc,
                     const std::vector<Eigen::Vector3d>& dp) const {
    double linear = 0, quadratic = 0;
    for (int c = 0; c < num_cameras_; ++c) {
      linear += lin.g_c[c].dot(dc[c]);
      quadratic += dc[c].dot(lin.h_cc[c] * dc[c]);
    }
    for (size_t p = 0; p < dp.size(); ++p) {
      linear += lin.g_p[p].dot(dp[p]);
      quadratic += dp[p].dot(lin.h_pp[p] * dp[p]);
    }
    for (int i : active_) {
      const int ci = camera_of(residuals_[i]);
      if (ci >= 0) quadratic += 2.0 * dc[ci].dot(lin.h_cp[i] * dp[residuals_[i].point]);
    }
    return linear + 0.5 * quadratic;
  }

  double MaxGradient(const Linearization& lin) const {
    double m = 0;
    for (const Vector6d& g : lin.g_c) m = std::max(m, g.lpNorm<Eigen::Infinity>());
    for (const Eigen::Vector3d& g : lin.g_p) m = std::max(m, g.lpNorm<Eigen::Infinity>());
    return m;
  }

  State Apply(const State& s, const std::vector<Vector6d>& dc,
              const std::vector<Eigen::Vector3d>& dp) const {
    State out = s;
    for (size_t k = 0; k < camera_of_pose_.size(); ++k) {
      const int c = camera_of_pose_[k];
      if (c < 0) continue;
      const Eigen::Quaterniond dq = ExpSO3(dc[c].tail<3>());
      out.rotation[k] = (dq * s.rotation[k]).normalized();
      out.translation[k] = dq * s.translation[k] + dc[c].head<3>();
    }
    for (size_t p = 0; p < dp.size(); ++p) out.points[p] += dp[p];
    return out;
  }

 private:
  template <int kRows>
  double Accumulate(int index, const BundleResidual& r, const Eigen::Matrix3d& rotation,
                    const State& s, Linearization* lin) const {
    const Eigen::Vector3d& x = s.points[r.point];
    const Eigen::Vector3d p = rotation * x + s.translation[r.pose];
    if (p.z() <= 1e-6) return 0.0;  // behind the camera: no residual (as cost_functions.cc)
    const ProjectionModel& m = model_;
    const double inv_z = 1.0 / p.z(), inv_z2 = inv_z * inv_z;
    const double u = m.fx * p.x() * inv_z + m.cx;
    Eigen::Matrix<double, kRows, 1> e;
    e(0) = (r.measurement.x() - u) * r.sqrt_info;
    e(1) = (r.measurement.y() - (m.fy * p.y() * inv_z + m.cy)) * r.sqrt_info;
    if constexpr (kRows == 3) e(2) = (r.measurement.z() - (u - m.bf * inv_z)) * r.sqrt_info;
    double rho, weight;
    Huber(e.squaredNorm(), kRows == 3 ? delta_stereo_ : delta_mono_, &rho, &weight);
    if (lin) {
      Eigen::Matrix<double, kRows, 3> d_e_d_p;
      d_e_d_p.row(0) << m.fx * inv_z, 0, -m.fx * p.x() * inv_z2;
      d_e_d_p.row(1) << 0, m.fy * inv_z, -m.fy * p.y() * inv_z2;
      if constexpr (kRows == 3)
        d_e_d_p.row(2) << m.fx * inv_z, 0, -m.fx * p.x() * inv_z2 + m.bf * inv_z2;
      d_e_d_p *= -r.sqrt_info;
      const Eigen::Matrix<double, kRows, 3> j_point = d_e_d_p * rotation;
      lin->h_pp[r.point].noalias() += weight * j_point.transpose() * j_point;
      lin->g_p[r.point].noalias() += weight * j_point.transpose() * e;
      lin->point_seen[r.point] = 1;
      const int c = camera_of_pose_[r.pose];
      if (c >= 0) {
        Eigen::Matrix<double, kRows, 6> j_pose;
        j_pose.template leftCols<3>() = d_e_d_p;
        j_pose.template rightCols<3>() = -d_e_d_p * SkewSymmetric(p);
        lin->h_cc[c].noalias() += weight * j_pose.transpose() * j_pose;
        lin->g_c[c].noalias() += weight * j_pose.transpose() * e;
        lin->h_cp[index].noalias() = weight * j_pose.transpose() * j_point;
      }
    }
    return 0.5 * rho;
  }

  const std::vector<BundleResidual>& residuals_;
  ProjectionModel model_;
  double delta_mono_, delta_stereo_;
  std::vector<int> camera_of_pose_;
  int num_cameras_ = 0;
  std::vector<Matrix6d> prior_information_;  // per camera
  std::vector<Rigid3d> prior_;               // per pose; empty: no prior
  std::vector<int> active_;
  std::vector<int> point_begin_, by_point_;
};

}  // namespace

void BundleSolverOptions::Check() const {
  CheckFields("BundleSolverOptions", "BundleSolverOptions.max_iterations", 0);
  DYGSLAM_CHECK_OPTION(prior_sigma_translation >= 0, "BundleSolverOptions.prior_sigma_translation");
  DYGSLAM_CHECK_OPTION(prior_sigma_rotation >= 0, "BundleSolverOptions.prior_sigma_rotation");
}

BundleSolverSummary SolveBundleProblem(const std::vector<BundleResidual>& residuals,
                                       const uint8_t* active, const ProjectionModel& model,
                                       double huber_delta_mono, double huber_delta_stereo,
                                       const BundleSolverOptions& options,
                                       const std::vector<uint8_t>& fixed,
                                       std::vector<std::array<double, 7>>* poses,
                                       std::vector<Eigen::Vector3d>* points,
                                       const std::atomic<bool>* abort) {
  if (fixed.size() != poses->size())
    throw std::invalid_argument("SolveBundleProblem: one fixed flag per pose");
  Problem problem(residuals, active, model, huber_delta_mono, huber_delta_stereo, fixed,
                  points->size());
  State state;
  for (const auto& params : *poses) {
    const Rigid3d pose = PoseFromParameters(params.data());
    state.rotation.push_back(pose.rotation);
    state.translation.push_back(pose.translation);
  }
  state.points = *points;
  BundleSolverSummary summary;
  Linearization lin, candidate_lin;
  double cost = problem.Evaluate(state, &lin);
  if (options.prior_sigma_translation > 0 && options.prior_sigma_rotation > 0) {
    problem.SetPrior(state, lin, options.prior_sigma_translation, options.prior_sigma_rotation);
    cost = problem.Evaluate(state, &lin);
  }
  summary.initial_cost = summary.final_cost = cost;
  double radius = options.initial_trust_radius, decrease_factor = 2.0;
  std::vector<Vector6d> dc;
  std::vector<Eigen::Vector3d> dp;
  while (summary.iterations < options.max_iterations) {
    if (abort && abort->load()) {
      summary.aborted = true;
      break;
    }
    if (problem.MaxGradient(lin) <= options.gradient_tolerance) break;
    ++summary.iterations;
    if (!problem.Step(lin, radius, &dc, &dp)) {
      radius /= decrease_factor;
      decrease_factor *= 2.0;
      continue;
    }
    double step_norm2 = 0, x_norm2 = 0;
    for (const Vector6d& d : dc) step_norm2 += d.squaredNorm();
    for (const Eigen::Vector3d& d : dp) step_norm2 += d.squaredNorm();
    for (size_t k = 0; k < state.rotation.size(); ++k)
      x_norm2 += state.translation[k].squaredNorm() + state.rotation[k].coeffs().squaredNorm();
    for (const Eigen::Vector3d& x : state.points) x_norm2 += x.squaredNorm();
    const double x_norm = std::sqrt(x_norm2);
    if (std::sqrt(step_norm2) <=
        (x_norm + options.parameter_tolerance) * options.parameter_tolerance)
      break;
    State candidate = problem.Apply(state, dc, dp);
    // Linearized at once: nearly every step is accepted, and then this is the next linearization.
    const double new_cost = problem.Evaluate(candidate, &candidate_lin);
    const double model_decrease = -problem.ModelChange(lin, dc, dp);
    const double ratio = model_decrease > 0 ? (cost - new_cost) / model_decrease : -1.0;
    if (!std::isfinite(new_cost) || ratio <= 1e-3) {
      radius /= decrease_factor;
      decrease_factor *= 2.0;
      continue;
    }
    const double cost_change = cost - new_cost;
    const double old_cost = cost;
    state = std::move(candidate);
    cost = new_cost;
    std::swap(lin, candidate_lin);
    ++summary.successful_iterations;
    const double factor = 1.0 - std::pow(2.0 * ratio - 1.0, 3);
    radius = std::min(radius / std::max(1.0 / 3.0, factor), 1e16);
    decrease_factor = 2.0;
    if (cost_change <= options.function_tolerance * old_cost) break;
  }
  summary.final_cost = cost;
  for (size_t k = 0; k < poses->size(); ++k)
    PoseToParameters(Rigid3d(state.rotation[k], state.translation[k]), (*poses)[k].data());
  *points = std::move(state.points);
  return summary;
}

}  // namespace dygslam
