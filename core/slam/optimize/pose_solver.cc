#include "core/slam/optimize/pose_solver.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>

#include "core/base/error.h"

namespace dygslam {
namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

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

// Residual (rows 0..rows-1) and, when h and g are given, the IRLS-weighted normal equations of
// one observation added in; returns 0.5 rho(|r|^2).
template <int kRows>
double Accumulate(const PoseObservation& o, const Eigen::Matrix3d& rotation,
                  const Eigen::Vector3d& t, const ProjectionModel& m, double delta, Matrix6d* h,
                  Vector6d* g) {
  const Eigen::Vector3d p = rotation * o.point + t;
  if (p.z() <= 1e-6)
    return 0.0;  // behind the camera: no residual, no gradient (as in cost_functions.cc)
  const double sqrt_info = std::sqrt(o.information);
  const double inv_z = 1.0 / p.z(), inv_z2 = inv_z * inv_z;
  const double u = m.fx * p.x() * inv_z + m.cx;
  Eigen::Matrix<double, kRows, 1> r;
  r(0) = (o.measurement.x() - u) * sqrt_info;
  r(1) = (o.measurement.y() - (m.fy * p.y() * inv_z + m.cy)) * sqrt_info;
  if constexpr (kRows == 3) r(2) = (o.measurement.z() - (u - m.bf * inv_z)) * sqrt_info;
  double rho, weight;
  Huber(r.squaredNorm(), delta, &rho, &weight);
  if (h) {
    Eigen::Matrix<double, kRows, 3> d_r_d_p;
    d_r_d_p.row(0) << m.fx * inv_z, 0, -m.fx * p.x() * inv_z2;
    d_r_d_p.row(1) << 0, m.fy * inv_z, -m.fy * p.y() * inv_z2;
    if constexpr (kRows == 3)
      d_r_d_p.row(2) << m.fx * inv_z, 0, -m.fx * p.x() * inv_z2 + m.bf * inv_z2;
    d_r_d_p *= -sqrt_info;
    Eigen::Matrix<double, kRows, 6> j;
    j.template leftCols<3>() = d_r_d_p;
    j.template rightCols<3>() = -d_r_d_p * SkewSymmetric(p);
    h->noalias() += weight * j.transpose() * j;
    g->noalias() += weight * j.transpose() * r;
  }
  return 0.5 * rho;
}

struct Evaluator {
  const std::vector<PoseObservation>& observations;
  const uint8_t* active;
  const ProjectionModel& model;
  double delta_mono, delta_stereo;
  const PosePrior* prior = nullptr;

  // Cost at (q, t); with h and g, also the normal equations (zeroed first).
  double operator()(const Eigen::Quaterniond& q, const Eigen::Vector3d& t, Matrix6d* h,
                    Vector6d* g) const {
    const Eigen::Matrix3d rotation = q.toRotationMatrix();
    if (h) {
      h->setZero();
      g->setZero();
    }
    double cost = 0;
    for (size_t i = 0; i < observations.size(); ++i) {
      if (active && !active[i]) continue;
      const PoseObservation& o = observations[i];
      cost += o.stereo ? Accumulate<3>(o, rotation, t, model, delta_stereo, h, g)
                       : Accumulate<2>(o, rotation, t, model, delta_mono, h, g);
    }
    if (prior) {
      const Vector6d e = PosePriorError(Rigid3d(q, t), prior->cam_from_world);
      const Vector6d information_e = prior->information * e;
      cost += 0.5 * e.dot(information_e);
      if (h) {
        *h += prior->information;
        *g += information_e;
      }
    }
    return cost;
  }
};

}  // namespace

void TrustRegionOptions::CheckFields(const std::string& name, const std::string& iterations_key,
                                     int min_iterations) const {
  if (min_iterations >= 1) {
    DYGSLAM_CHECK_OPTION(max_iterations >= 1, iterations_key);
  } else {
    DYGSLAM_CHECK_OPTION(max_iterations >= 0, iterations_key);
  }
  DYGSLAM_CHECK_OPTION(initial_trust_radius > 0, name + ".initial_trust_radius");
  DYGSLAM_CHECK_OPTION(function_tolerance >= 0, name + ".function_tolerance");
  DYGSLAM_CHECK_OPTION(gradient_tolerance >= 0, name + ".gradient_tolerance");
  DYGSLAM_CHECK_OPTION(parameter_tolerance >= 0, name + ".parameter_tolerance");
}

void PoseSolverOptions::Check() const {
  CheckFields("PoseSolverOptions", "Optimizer.pose_iterations", 1);
}

PoseSolverSummary SolvePose(const std::vector<PoseObservation>& observations, const uint8_t* active,
                            const ProjectionModel& model, double huber_delta_mono,
                            double huber_delta_stereo, const PoseSolverOptions& options,
                            Rigid3d* cam_from_world, const PosePrior* prior) {
  const Evaluator evaluate{observations,       active, model, huber_delta_mono,
                           huber_delta_stereo, prior};
  Eigen::Quaterniond q = cam_from_world->rotation.normalized();
  Eigen::Vector3d t = cam_from_world->translation;
  Matrix6d h, h_new;
  Vector6d g, g_new;
  PoseSolverSummary summary;
  double cost = evaluate(q, t, &h, &g);
  summary.initial_cost = summary.final_cost = cost;
  double radius = options.initial_trust_radius, decrease_factor = 2.0;
  while (summary.iterations < options.max_iterations) {
    if (g.lpNorm<Eigen::Infinity>() <= options.gradient_tolerance) break;
    ++summary.iterations;
    Matrix6d damped = h;
    for (int i = 0; i < 6; ++i) damped(i, i) += std::clamp(h(i, i), 1e-6, 1e32) / radius;
    const Eigen::LDLT<Matrix6d> ldlt(damped);
    const Vector6d step = ldlt.solve(-g);
    if (ldlt.info() != Eigen::Success || !step.allFinite()) {
      radius /= decrease_factor;
      decrease_factor *= 2.0;
      continue;
    }
    const double x_norm = std::sqrt(t.squaredNorm() + q.coeffs().squaredNorm());
    if (step.norm() <= (x_norm + options.parameter_tolerance) * options.parameter_tolerance) break;
    const Eigen::Quaterniond dq = ExpSO3(step.tail<3>());
    const Eigen::Quaterniond q_new = (dq * q).normalized();
    const Eigen::Vector3d t_new = dq * t + step.head<3>();
    const double new_cost = evaluate(q_new, t_new, &h_new, &g_new);
    // The linear model's decrease: -(g' step + 0.5 step' H step).
    const double model_decrease = -(g.dot(step) + 0.5 * step.dot(h * step));
    const double ratio = model_decrease > 0 ? (cost - new_cost) / model_decrease : -1.0;
    if (!std::isfinite(new_cost) || ratio <= 1e-3) {
      radius /= decrease_factor;
      decrease_factor *= 2.0;
      continue;
    }
    const double cost_change = cost - new_cost;
    const double old_cost = cost;
    q = q_new;
    t = t_new;
    cost = new_cost;
    h = h_new;
    g = g_new;
    ++summary.successful_iterations;
    const double factor = 1.0 - std::pow(2.0 * ratio - 1.0, 3);
    radius = std::min(radius / std::max(1.0 / 3.0, factor), 1e16);
    decrease_factor = 2.0;
    if (cost_change <= options.function_tolerance * old_cost) break;
  }
  summary.final_cost = cost;
  *cam_from_world = Rigid3d(q, t);
  return summary;
}

Eigen::Matrix<double, 6, 6> PoseInformation(const std::vector<PoseObservation>& observations,
                                            const uint8_t* active, const ProjectionModel& model,
                                            double huber_delta_mono, double huber_delta_stereo,
                                            const Rigid3d& cam_from_world) {
  const Evaluator evaluate{observations, active, model, huber_delta_mono, huber_delta_stereo};
  Matrix6d h;
  Vector6d g;
  evaluate(cam_from_world.rotation.normalized(), cam_from_world.translation, &h, &g);
  return h;
}

}  // namespace dygslam
