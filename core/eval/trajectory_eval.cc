#include "core/eval/trajectory_eval.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

#include "core/base/error.h"
#include "core/io/association.h"

namespace dygslam {
namespace {

double Median(std::vector<double> v) {
  // numpy.median: mean of the two middle values for even sizes.
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

std::vector<Timestamp> StampsOf(const std::vector<StampedPose>& poses) {
  std::vector<Timestamp> out;
  out.reserve(poses.size());
  for (const StampedPose& p : poses) out.push_back(p.stamp);
  return out;
}

void RequireSorted(const std::vector<StampedPose>& poses, const char* what) {
  for (size_t i = 1; i < poses.size(); ++i) {
    if (!(poses[i - 1].stamp < poses[i].stamp)) {
      throw InputError(std::string(what) + ": poses not strictly sorted by timestamp at " +
                       poses[i].stamp.ToString());
    }
  }
}

// Index of the element of sorted `stamps` closest to t (ties: the earlier one).
size_t ClosestIndex(const std::vector<int64_t>& stamps, int64_t t) {
  auto it = std::lower_bound(stamps.begin(), stamps.end(), t);
  if (it == stamps.begin()) return 0;
  if (it == stamps.end()) return stamps.size() - 1;
  const size_t hi = static_cast<size_t>(it - stamps.begin());
  return (t - stamps[hi - 1] <= stamps[hi] - t) ? hi - 1 : hi;
}

}  // namespace

ErrorStatistics ComputeErrorStatistics(const std::vector<double>& errors) {
  if (errors.empty()) throw std::invalid_argument("ComputeErrorStatistics: no errors");
  ErrorStatistics s;
  double sum = 0, sum_sq = 0;
  s.min = s.max = errors[0];
  for (double e : errors) {
    sum += e;
    sum_sq += e * e;
    s.min = std::min(s.min, e);
    s.max = std::max(s.max, e);
  }
  const double n = static_cast<double>(errors.size());
  s.rmse = std::sqrt(sum_sq / n);
  s.mean = sum / n;
  double var = 0;
  for (double e : errors) var += (e - s.mean) * (e - s.mean);
  s.sd = std::sqrt(var / n);
  s.median = Median(errors);
  return s;
}

void AteOptions::Check() const {
  DYGSLAM_CHECK_OPTION(std::isfinite(max_time_difference) && max_time_difference > 0,
                       "max_time_difference");
  DYGSLAM_CHECK_OPTION(std::isfinite(offset), "offset");
}

void RpeOptions::Check() const {
  DYGSLAM_CHECK_OPTION(std::isfinite(delta) && delta > 0, "delta");
  DYGSLAM_CHECK_OPTION(std::isfinite(offset), "offset");
}

Rigid3d AlignRigid(const std::vector<Eigen::Vector3d>& source,
                   const std::vector<Eigen::Vector3d>& target) {
  if (source.size() != target.size() || source.size() < 3) {
    throw std::invalid_argument("AlignRigid: needs >= 3 point pairs of equal count");
  }
  const double n = static_cast<double>(source.size());
  Eigen::Vector3d mean_s = Eigen::Vector3d::Zero(), mean_t = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < source.size(); ++i) {
    mean_s += source[i];
    mean_t += target[i];
  }
  mean_s /= n;
  mean_t /= n;
  // Cross-covariance H = sum (s - mean_s)(t - mean_t)^T; R = V diag(1, 1, det(V U^T)) U^T.
  Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < source.size(); ++i) {
    h += (source[i] - mean_s) * (target[i] - mean_t).transpose();
  }
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  if ((svd.matrixV() * svd.matrixU().transpose()).determinant() < 0) d(2, 2) = -1;
  const Eigen::Matrix3d r = svd.matrixV() * d * svd.matrixU().transpose();
  return Rigid3d(r, mean_t - r * mean_s);
}

AteResult ComputeAte(const std::vector<StampedPose>& groundtruth,
                     const std::vector<StampedPose>& estimate, const AteOptions& options) {
  options.Check();
  RequireSorted(groundtruth, "ground truth");
  RequireSorted(estimate, "estimate");
  // evaluate_ate.py: associate(first=ground truth, second=estimate, offset, max_difference).
  const std::vector<TimestampMatch> matches = AssociateTimestamps(
      StampsOf(groundtruth), StampsOf(estimate), options.max_time_difference, options.offset);
  if (matches.size() < 3) {
    throw InputError(
        "ATE: only " + std::to_string(matches.size()) + " ground-truth/estimate pairs within " +
        std::to_string(options.max_time_difference) + " s (" + std::to_string(groundtruth.size()) +
        " ground-truth poses, " + std::to_string(estimate.size()) +
        " estimated poses); need at least 3. Wrong files or time base?");
  }
  AteResult r;
  r.num_pairs = matches.size();
  std::vector<Eigen::Vector3d> est_positions;
  for (const TimestampMatch& m : matches) {
    r.gt_stamps.push_back(groundtruth[m.first].stamp);
    r.est_stamps.push_back(estimate[m.second].stamp);
    r.gt_positions.push_back(groundtruth[m.first].world_from_cam.translation);
    est_positions.push_back(estimate[m.second].world_from_cam.translation);
  }
  r.gt_from_est = AlignRigid(est_positions, r.gt_positions);
  for (size_t i = 0; i < matches.size(); ++i) {
    r.aligned_positions.push_back(r.gt_from_est * est_positions[i]);
    r.errors.push_back((r.aligned_positions[i] - r.gt_positions[i]).norm());
  }
  r.error = ComputeErrorStatistics(r.errors);
  r.aligned_estimate.reserve(estimate.size());
  for (const StampedPose& p : estimate) {
    r.aligned_estimate.push_back({p.stamp, r.gt_from_est * p.world_from_cam});
  }
  return r;
}

RpeResult ComputeRpe(const std::vector<StampedPose>& groundtruth,
                     const std::vector<StampedPose>& estimate, const RpeOptions& options) {
  options.Check();
  RequireSorted(groundtruth, "ground truth");
  RequireSorted(estimate, "estimate");
  RpeResult r;
  r.delta = options.delta;
  if (groundtruth.size() < 2 || estimate.size() < 2) return r;
  std::vector<int64_t> gt_ns, est_ns;
  for (const StampedPose& p : groundtruth) gt_ns.push_back(p.stamp.nanoseconds());
  for (const StampedPose& p : estimate) est_ns.push_back(p.stamp.nanoseconds());
  const int64_t offset_ns = static_cast<int64_t>(std::llround(options.offset * 1e9));
  const int64_t delta_ns = static_cast<int64_t>(std::llround(options.delta * 1e9));

  std::vector<double> intervals;
  for (size_t i = 1; i < gt_ns.size(); ++i) intervals.push_back(double(gt_ns[i] - gt_ns[i - 1]));
  const double gt_max_difference_ns = 2.0 * Median(intervals);

  for (size_t i = 0; i < est_ns.size(); ++i) {
    const size_t j = ClosestIndex(est_ns, est_ns[i] + delta_ns);
    if (j == est_ns.size() - 1) continue;  // as evaluate_rpe.py (fixed delta)
    const size_t gi = ClosestIndex(gt_ns, est_ns[i] + offset_ns);
    const size_t gj = ClosestIndex(gt_ns, est_ns[j] + offset_ns);
    if (std::abs(double(gt_ns[gi] - (est_ns[i] + offset_ns))) > gt_max_difference_ns ||
        std::abs(double(gt_ns[gj] - (est_ns[j] + offset_ns))) > gt_max_difference_ns) {
      continue;
    }
    const Rigid3d est_rel = estimate[i].world_from_cam.Inverse() * estimate[j].world_from_cam;
    const Rigid3d gt_rel =
        groundtruth[gi].world_from_cam.Inverse() * groundtruth[gj].world_from_cam;
    // evaluate_rpe.py: ominus(ominus(est_j, est_i), ominus(gt_j, gt_i)) with ominus(a, b) = a^-1 b,
    // i.e. error = (est_j^-1 est_i)^-1 (gt_j^-1 gt_i) = est_rel * gt_rel^-1.
    const Rigid3d error = est_rel * gt_rel.Inverse();
    r.trans_errors.push_back(error.translation.norm());
    r.rot_errors.push_back(RotationAngle(error.rotation) * 180.0 / M_PI);
  }
  r.num_pairs = r.trans_errors.size();
  if (r.num_pairs == 0) return r;
  const ErrorStatistics t = ComputeErrorStatistics(r.trans_errors);
  const ErrorStatistics a = ComputeErrorStatistics(r.rot_errors);
  r.trans_rmse = t.rmse;
  r.trans_mean = t.mean;
  r.trans_median = t.median;
  r.rot_rmse = a.rmse;
  r.rot_mean = a.mean;
  r.rot_median = a.median;
  return r;
}

std::vector<StampedPose> MoveGroundTruthToCamera(const std::vector<StampedPose>& groundtruth,
                                                 const Rigid3d& body_from_cam) {
  std::vector<StampedPose> out;
  out.reserve(groundtruth.size());
  for (const StampedPose& p : groundtruth)
    out.push_back({p.stamp, p.world_from_cam * body_from_cam});
  return out;
}

Rigid3d BonnMarkerFromCamera() {
  Eigen::Matrix4d t_ros;
  t_ros << -1, 0, 0, 0, 0, 0, 1, 0, 0, 1, 0, 0, 0, 0, 0, 1;
  Eigen::Matrix4d t_m;
  t_m << 1.0157, 0.1828, -0.2389, 0.0113,  //
      0.0009, -0.8431, -0.6413, -0.0098,   //
      -0.3009, 0.6147, -0.8085, 0.0111,    //
      0, 0, 0, 1;
  const Eigen::Matrix4d m = t_ros * t_m;
  // Nearest rotation to the scaled 3x3 block: U V^T of its SVD.
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(m.topLeftCorner<3, 3>(),
                                              Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d r = svd.matrixU() * svd.matrixV().transpose();
  if (r.determinant() < 0) {
    Eigen::Matrix3d u = svd.matrixU();
    u.col(2) *= -1;
    r = u * svd.matrixV().transpose();
  }
  return Rigid3d(r, m.topRightCorner<3, 1>());
}

std::string AtePairsText(const AteResult& ate) {
  std::string text = "# t gt_x gt_y gt_z est_x est_y est_z error (aligned estimate, metres)\n";
  char line[256];
  for (size_t i = 0; i < ate.num_pairs; ++i) {
    const auto& g = ate.gt_positions[i];
    const auto& e = ate.aligned_positions[i];
    std::snprintf(line, sizeof(line), "%s %.9g %.9g %.9g %.9g %.9g %.9g %.9g\n",
                  ate.gt_stamps[i].ToString().c_str(), g.x(), g.y(), g.z(), e.x(), e.y(), e.z(),
                  ate.errors[i]);
    text += line;
  }
  return text;
}

}  // namespace dygslam
