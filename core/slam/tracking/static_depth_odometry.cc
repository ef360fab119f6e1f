#include "core/slam/tracking/static_depth_odometry.h"

#include <chrono>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <opencv2/rgbd.hpp>

namespace dygslam {

void StaticDepthOdometryOptions::Check() const {
  DYGSLAM_CHECK_OPTION(min_depth >= 0 && std::isfinite(min_depth), "StaticDepthOdometry.min_depth");
  DYGSLAM_CHECK_OPTION(max_depth > min_depth && std::isfinite(max_depth),
                       "StaticDepthOdometry.max_depth");
  DYGSLAM_CHECK_OPTION(max_depth_diff > 0 && std::isfinite(max_depth_diff),
                       "StaticDepthOdometry.max_depth_diff");
  DYGSLAM_CHECK_OPTION(max_points_part > 0 && max_points_part <= 1,
                       "StaticDepthOdometry.max_points_part");
  DYGSLAM_CHECK_OPTION(!iteration_counts.empty(), "StaticDepthOdometry.iteration_counts");
  for (int n : iteration_counts)
    DYGSLAM_CHECK_OPTION(n > 0, "StaticDepthOdometry.iteration_counts");
  DYGSLAM_CHECK_OPTION(align_downsample >= 1 && align_downsample <= 4,
                       "StaticDepthOdometry.align_downsample");
  DYGSLAM_CHECK_OPTION(verify_step_px >= 1, "StaticDepthOdometry.verify_step_px");
  DYGSLAM_CHECK_OPTION(inlier_depth_tol > 0 && std::isfinite(inlier_depth_tol),
                       "StaticDepthOdometry.inlier_depth_tol");
  DYGSLAM_CHECK_OPTION(inlier_depth_tol_per_m2 >= 0 && std::isfinite(inlier_depth_tol_per_m2),
                       "StaticDepthOdometry.inlier_depth_tol_per_m2");
  DYGSLAM_CHECK_OPTION(min_inlier_fraction > 0 && min_inlier_fraction <= 1,
                       "StaticDepthOdometry.min_inlier_fraction");
  DYGSLAM_CHECK_OPTION(min_inliers >= 1, "StaticDepthOdometry.min_inliers");
  DYGSLAM_CHECK_OPTION(max_translation_from_seed > 0,
                       "StaticDepthOdometry.max_translation_from_seed");
  DYGSLAM_CHECK_OPTION(max_rotation_from_seed_deg > 0,
                       "StaticDepthOdometry.max_rotation_from_seed_deg");
  DYGSLAM_CHECK_OPTION(prior_sigma_translation > 0 && std::isfinite(prior_sigma_translation),
                       "StaticDepthOdometry.prior_sigma_translation");
  DYGSLAM_CHECK_OPTION(prior_sigma_rotation_deg > 0 && std::isfinite(prior_sigma_rotation_deg),
                       "StaticDepthOdometry.prior_sigma_rotation_deg");
  DYGSLAM_CHECK_OPTION(point_sigma > 0 && std::isfinite(point_sigma),
                       "StaticDepthOdometry.point_sigma");
  DYGSLAM_CHECK_OPTION(intensity_sigma >= 0 && std::isfinite(intensity_sigma),
                       "StaticDepthOdometry.intensity_sigma");
  DYGSLAM_CHECK_OPTION(constrained_step_px >= 1, "StaticDepthOdometry.constrained_step_px");
  DYGSLAM_CHECK_OPTION(constrained_iterations >= 1, "StaticDepthOdometry.constrained_iterations");
  DYGSLAM_CHECK_OPTION(constrained_min_inliers >= 1, "StaticDepthOdometry.constrained_min_inliers");
}

StaticDepthOdometry::StaticDepthOdometry(const PinholeCamera& camera,
                                         const StaticDepthOdometryOptions& options)
    : camera_(camera), options_(options) {
  camera_.Check();
  options_.Check();
  // The camera of the reduced images (pixel centres stay on pixel centres).
  const double s = options_.align_downsample;
  cv::Mat k = cv::Mat::eye(3, 3, CV_32F);
  k.at<float>(0, 0) = static_cast<float>(camera_.fx / s);
  k.at<float>(1, 1) = static_cast<float>(camera_.fy / s);
  k.at<float>(0, 2) = static_cast<float>((camera_.cx + 0.5) / s - 0.5);
  k.at<float>(1, 2) = static_cast<float>((camera_.cy + 0.5) / s - 0.5);
  const float min_depth = static_cast<float>(options_.min_depth);
  const float max_depth = static_cast<float>(options_.max_depth);
  const float max_depth_diff = static_cast<float>(options_.max_depth_diff);
  const float max_points_part = static_cast<float>(options_.max_points_part);
  switch (options_.alignment) {
    case DenseAlignment::kRgbdIcp: {
      auto o = cv::makePtr<cv::rgbd::RgbdICPOdometry>(k, min_depth, max_depth, max_depth_diff,
                                                      max_points_part, options_.iteration_counts);
      // The jump test is done against the seed in Estimate (OpenCV tests against the identity).
      o->setMaxTranslation(1e3);
      o->setMaxRotation(180.0);
      odometry_ = o;
      break;
    }
    case DenseAlignment::kIcp: {
      auto o = cv::makePtr<cv::rgbd::ICPOdometry>(k, min_depth, max_depth, max_depth_diff,
                                                  max_points_part, options_.iteration_counts);
      o->setMaxTranslation(1e3);
      o->setMaxRotation(180.0);
      odometry_ = o;
      break;
    }
    case DenseAlignment::kPhotometric: {
      auto o = cv::makePtr<cv::rgbd::RgbdOdometry>(k, min_depth, max_depth, max_depth_diff,
                                                   options_.iteration_counts);
      o->setMaxTranslation(1e3);
      o->setMaxRotation(180.0);
      odometry_ = o;
      break;
    }
  }
  // OpenCV's ICP odometries set up their normal estimator (tables for the image size) on the
  // first frame they see, which took ~150 ms: done here, at start-up, and not on the first frame
  // that needs the fallback (in the middle of a crowd, where every millisecond counts).
  if (options_.alignment != DenseAlignment::kPhotometric) {
    const cv::Size size = AlignSize();
    const cv::Mat depth(size, CV_32FC1, cv::Scalar(1.0f));
    const cv::Mat gray(size, CV_8UC1, cv::Scalar(128));
    const cv::Mat mask(size, CV_8UC1, cv::Scalar(255));
    cv::Ptr<cv::rgbd::OdometryFrame> frame =
        cv::makePtr<cv::rgbd::OdometryFrame>(gray, depth, mask, cv::Mat(), -1);
    odometry_->prepareFrameCache(frame, cv::rgbd::OdometryFrame::CACHE_ALL);
  }
}

StaticDepthOdometry::~StaticDepthOdometry() = default;

cv::Size StaticDepthOdometry::AlignSize() const {
  const int s = options_.align_downsample;
  return cv::Size((camera_.width + s - 1) / s, (camera_.height + s - 1) / s);
}

void StaticDepthOdometry::CheckView(const DenseView& view, const char* which) const {
  const cv::Size size(camera_.width, camera_.height);
  if (view.gray.empty() || view.gray.type() != CV_8UC1 || view.gray.size() != size)
    throw InputError(std::string("static depth odometry: ") + which +
                     " gray image must be CV_8UC1 of Camera.width x Camera.height");
  if (view.depth.empty() || view.depth.type() != CV_32FC1 || view.depth.size() != size)
    throw InputError(std::string("static depth odometry: ") + which +
                     " depth must be CV_32FC1 metres of Camera.width x Camera.height");
  const cv::Mat& mask = view.StaticMask();
  if (!mask.empty() && (mask.type() != CV_8UC1 || mask.size() != size))
    throw InputError(std::string("static depth odometry: ") + which +
                     " static mask must be CV_8UC1 of Camera.width x Camera.height");
}

DepthAgreement StaticDepthOdometry::Agreement(const DenseView& reference, const DenseView& current,
                                              const Rigid3d& cur_from_ref) const {
  CheckView(reference, "reference");
  CheckView(current, "current");
  const Rigid3d ref_from_cur = cur_from_ref.Inverse();
  const Eigen::Matrix3d r = ref_from_cur.RotationMatrix();
  const Eigen::Vector3d t = ref_from_cur.translation;
  DepthAgreement a;
  double sum_sq = 0;
  const int step = options_.verify_step_px;
  const cv::Mat& current_mask = current.StaticMask();
  const cv::Mat& reference_mask = reference.StaticMask();
  for (int v = 0; v < camera_.height; v += step) {
    const float* depth_row = current.depth.ptr<float>(v);
    const uint8_t* mask_row = current_mask.empty() ? nullptr : current_mask.ptr<uint8_t>(v);
    for (int u = 0; u < camera_.width; u += step) {
      const float d = depth_row[u];
      if (!(d > options_.min_depth && d < options_.max_depth)) continue;
      if (mask_row && !mask_row[u]) continue;
      ++a.samples;
      const Eigen::Vector3d p = r * camera_.Unproject(u, v, d) + t;
      if (p.z() <= options_.min_depth) continue;
      const double pu = camera_.fx * p.x() / p.z() + camera_.cx;
      const double pv = camera_.fy * p.y() / p.z() + camera_.cy;
      const int iu = static_cast<int>(std::lround(pu)), iv = static_cast<int>(std::lround(pv));
      if (iu < 0 || iv < 0 || iu >= camera_.width || iv >= camera_.height) continue;
      if (!reference_mask.empty() && !reference_mask.at<uint8_t>(iv, iu)) continue;
      const float dr = reference.depth.at<float>(iv, iu);
      if (!(dr > options_.min_depth && dr < options_.max_depth)) continue;
      ++a.correspondences;
      const double err = p.z() - dr;
      const double tol = options_.inlier_depth_tol + options_.inlier_depth_tol_per_m2 * dr * dr;
      if (std::abs(err) <= tol) {
        ++a.inliers;
        sum_sq += err * err;
      }
    }
  }
  a.rmse = a.inliers > 0 ? std::sqrt(sum_sq / a.inliers) : 0;
  return a;
}

StaticDepthEstimate StaticDepthOdometry::Estimate(const DenseView& reference,
                                                  const DenseView& current,
                                                  const Rigid3d& cur_from_ref_seed) const {
  CheckView(reference, "reference");
  CheckView(current, "current");
  const auto t0 = std::chrono::steady_clock::now();
  StaticDepthEstimate e;
  const cv::Size align_size = AlignSize();
  auto odometry_frame = [&align_size](const DenseView& view) {
    if (view.odometry_frame) return view.odometry_frame;
    cv::Mat gray = view.gray, depth = view.depth, mask;
    if (view.StaticMask().empty()) {
      mask = cv::Mat(view.depth.size(), CV_8UC1, cv::Scalar(255));
    } else {
      mask = view.StaticMask().clone();
    }
    // Pixels without depth are not usable either (OpenCV also tests the range, but a NaN-free
    // mask keeps its normal computation away from holes).
    mask.setTo(0, view.depth <= 0);
    if (align_size != view.depth.size()) {
      cv::resize(view.gray, gray, align_size, 0, 0, cv::INTER_AREA);
      cv::resize(view.depth, depth, align_size, 0, 0, cv::INTER_NEAREST);
      cv::resize(mask, mask, align_size, 0, 0, cv::INTER_NEAREST);
    }
    view.odometry_frame = cv::makePtr<cv::rgbd::OdometryFrame>(gray, depth, mask, cv::Mat(), -1);
    return view.odometry_frame;
  };
  cv::Ptr<cv::rgbd::OdometryFrame> src = odometry_frame(reference);
  cv::Ptr<cv::rgbd::OdometryFrame> dst = odometry_frame(current);
  cv::Mat init(4, 4, CV_64F);
  const Eigen::Matrix4d seed = cur_from_ref_seed.ToMatrix();
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) init.at<double>(i, j) = seed(i, j);
  cv::Mat rt;
  bool ok = false;
  try {
    ok = odometry_->compute(src, dst, rt, init);
  } catch (const cv::Exception&) {
    ok = false;  // too few valid pixels on a pyramid level: no estimate
  }
  if (ok && rt.type() == CV_64FC1 && rt.rows == 4 && rt.cols == 4 && cv::checkRange(rt)) {
    Eigen::Matrix3d r;
    Eigen::Vector3d t;
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) r(i, j) = rt.at<double>(i, j);
      t(i) = rt.at<double>(i, 3);
    }
    e.converged = true;
    e.cur_from_ref = Rigid3d(r, t);
    const Rigid3d jump = e.cur_from_ref * cur_from_ref_seed.Inverse();
    const bool near_seed =
        jump.translation.norm() <= options_.max_translation_from_seed &&
        RotationAngle(jump.rotation) * 180.0 / M_PI <= options_.max_rotation_from_seed_deg;
    e.agreement = Agreement(reference, current, e.cur_from_ref);
    e.verified = near_seed && e.agreement.inliers >= options_.min_inliers &&
                 e.agreement.inlier_fraction() >= options_.min_inlier_fraction;
  }
  e.time_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return e;
}

namespace {

// Bilinear intensity of an 8-bit image at (x, y); false outside [0, w-1) x [0, h-1).
bool Bilinear(const cv::Mat& gray, double x, double y, double* value) {
  if (!(x >= 0 && y >= 0 && x < gray.cols - 1 && y < gray.rows - 1)) return false;
  const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
  const double ax = x - x0, ay = y - y0;
  const uint8_t* r0 = gray.ptr<uint8_t>(y0) + x0;
  const uint8_t* r1 = gray.ptr<uint8_t>(y0 + 1) + x0;
  *value = (1 - ay) * ((1 - ax) * r0[0] + ax * r0[1]) + ay * ((1 - ax) * r1[0] + ax * r1[1]);
  return true;
}

// exp of a twist (rotation vector w, translation v), applied on the left: a small motion.
Rigid3d ExpTwist(const Eigen::Vector3d& w, const Eigen::Vector3d& v) {
  const double angle = w.norm();
  const Eigen::Quaterniond q = angle > 1e-12
                                   ? Eigen::Quaterniond(Eigen::AngleAxisd(angle, w / angle))
                                   : Eigen::Quaterniond::Identity();
  return Rigid3d(q, v);
}

}  // namespace

StaticDepthEstimate StaticDepthOdometry::EstimateWithPrior(const DenseView& reference,
                                                           const DenseView& current,
                                                           const Rigid3d& cur_from_ref_seed) const {
  CheckView(reference, "reference");
  CheckView(current, "current");
  const auto t0 = std::chrono::steady_clock::now();
  const cv::Mat& current_mask = current.StaticMask();
  const cv::Mat& reference_mask = reference.StaticMask();
  auto valid_depth = [this](float d) { return d > options_.min_depth && d < options_.max_depth; };
  // Reference points with their normals, taken where a current point projects (the normal from the
  // neighbours `k` pixels away on both sides; none across a depth edge).
  const int k = 2;
  auto reference_point = [&](int u, int v, Eigen::Vector3d* q, Eigen::Vector3d* n) {
    if (u < k || v < k || u + k >= camera_.width || v + k >= camera_.height) return false;
    if (!reference_mask.empty() && !reference_mask.at<uint8_t>(v, u)) return false;
    const float d = reference.depth.at<float>(v, u);
    const float dl = reference.depth.at<float>(v, u - k), dr = reference.depth.at<float>(v, u + k);
    const float du = reference.depth.at<float>(v - k, u), dd = reference.depth.at<float>(v + k, u);
    if (!valid_depth(d) || !valid_depth(dl) || !valid_depth(dr) || !valid_depth(du) ||
        !valid_depth(dd))
      return false;
    const float edge = static_cast<float>(options_.max_depth_diff);
    if (std::abs(dl - dr) > edge || std::abs(du - dd) > edge) return false;
    *q = camera_.Unproject(u, v, d);
    const Eigen::Vector3d tx = camera_.Unproject(u + k, v, dr) - camera_.Unproject(u - k, v, dl);
    const Eigen::Vector3d ty = camera_.Unproject(u, v + k, dd) - camera_.Unproject(u, v - k, du);
    Eigen::Vector3d normal = tx.cross(ty);
    const double norm = normal.norm();
    if (!(norm > 0)) return false;
    normal /= norm;
    if (normal.dot(*q) > 0) normal = -normal;
    *n = normal;
    return true;
  };
  // The current frame's static points (sampled once).
  std::vector<Eigen::Vector3d> points;
  std::vector<double> intensities;
  const int step = options_.constrained_step_px;
  for (int v = 0; v < camera_.height; v += step) {
    const float* depth_row = current.depth.ptr<float>(v);
    const uint8_t* gray_row = current.gray.ptr<uint8_t>(v);
    const uint8_t* mask_row = current_mask.empty() ? nullptr : current_mask.ptr<uint8_t>(v);
    for (int u = 0; u < camera_.width; u += step) {
      if (!valid_depth(depth_row[u]) || (mask_row && !mask_row[u])) continue;
      points.push_back(camera_.Unproject(u, v, depth_row[u]));
      intensities.push_back(gray_row[u]);
    }
  }
  const bool photometric = options_.intensity_sigma > 0;
  const double wi = photometric ? 1.0 / (options_.intensity_sigma * options_.intensity_sigma) : 0;
  const double huber_i = 2.0 * options_.intensity_sigma;
  StaticDepthEstimate e;
  const Rigid3d seed = cur_from_ref_seed.Inverse();  // ref_from_cur
  Rigid3d ref_from_cur = seed;
  const double wr = 1.0 / std::pow(options_.prior_sigma_rotation_deg * M_PI / 180.0, 2);
  const double wt = 1.0 / std::pow(options_.prior_sigma_translation, 2);
  const double wp = 1.0 / (options_.point_sigma * options_.point_sigma);
  const double huber = 2.0 * options_.point_sigma;
  bool solved = false;
  for (int it = 0; it < options_.constrained_iterations; ++it) {
    Eigen::Matrix<double, 6, 6> h = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> b = Eigen::Matrix<double, 6, 1>::Zero();
    const Eigen::Matrix3d r = ref_from_cur.RotationMatrix();
    const Eigen::Vector3d t = ref_from_cur.translation;
    int used = 0;
    for (size_t i = 0; i < points.size(); ++i) {
      const Eigen::Vector3d x = r * points[i] + t;  // in the reference camera
      if (x.z() <= options_.min_depth) continue;
      const double pu = camera_.fx * x.x() / x.z() + camera_.cx;
      const double pv = camera_.fy * x.y() / x.z() + camera_.cy;
      if (photometric) {
        // Intensity residual where the point lands on reference static pixels.
        const int ru = static_cast<int>(std::lround(pu)), rv = static_cast<int>(std::lround(pv));
        double i0, il, ir, iu_, id;
        if (ru >= 0 && rv >= 0 && ru < camera_.width && rv < camera_.height &&
            (reference_mask.empty() || reference_mask.at<uint8_t>(rv, ru)) &&
            Bilinear(reference.gray, pu, pv, &i0) && Bilinear(reference.gray, pu - 1, pv, &il) &&
            Bilinear(reference.gray, pu + 1, pv, &ir) &&
            Bilinear(reference.gray, pu, pv - 1, &iu_) &&
            Bilinear(reference.gray, pu, pv + 1, &id)) {
          const double gx = 0.5 * (ir - il), gy = 0.5 * (id - iu_);
          const double iz = 1.0 / x.z();
          // d intensity / d x (through the projection).
          const Eigen::Vector3d a(gx * camera_.fx * iz, gy * camera_.fy * iz,
                                  -(gx * camera_.fx * x.x() + gy * camera_.fy * x.y()) * iz * iz);
          const double res = i0 - intensities[i];
          Eigen::Matrix<double, 6, 1> j;
          j << x.cross(a), a;
          const double w = wi * (std::abs(res) <= huber_i ? 1.0 : huber_i / std::abs(res));
          h += w * j * j.transpose();
          b -= w * j * res;
        }
      }
      const int iu = static_cast<int>(std::lround(pu));
      const int iv = static_cast<int>(std::lround(pv));
      Eigen::Vector3d q, n;
      if (!reference_point(iu, iv, &q, &n)) continue;
      if (std::abs(x.z() - q.z()) > options_.max_depth_diff) continue;
      const double res = n.dot(x - q);
      // Left perturbation of ref_from_cur by (w, v): d x = -[x]x w + v.
      Eigen::Matrix<double, 6, 1> j;
      j << x.cross(n), n;
      const double w = wp * (std::abs(res) <= huber ? 1.0 : huber / std::abs(res));
      h += w * j * j.transpose();
      b -= w * j * res;
      ++used;
    }
    if (used < 6) break;
    // The prior: ref_from_cur = exp(e) * seed, e ~ N(0, diag(sigma_r^2 x3, sigma_t^2 x3)).
    const Rigid3d diff = ref_from_cur * seed.Inverse();
    const Eigen::AngleAxisd aa(diff.rotation);
    Eigen::Matrix<double, 6, 1> prior_residual;
    prior_residual << aa.angle() * aa.axis(), diff.translation;
    for (int i = 0; i < 6; ++i) {
      const double wi = i < 3 ? wr : wt;
      h(i, i) += wi;
      b(i) -= wi * prior_residual(i);
    }
    const Eigen::Matrix<double, 6, 1> delta = h.ldlt().solve(b);
    if (!delta.allFinite()) break;
    ref_from_cur = ExpTwist(delta.head<3>(), delta.tail<3>()) * ref_from_cur;
    solved = true;
    if (delta.head<3>().norm() < 1e-6 && delta.tail<3>().norm() < 1e-5) break;
  }
  if (solved) {
    e.converged = true;
    e.cur_from_ref = ref_from_cur.Inverse();
    const Rigid3d jump = e.cur_from_ref * cur_from_ref_seed.Inverse();
    const bool near_seed =
        jump.translation.norm() <= options_.max_translation_from_seed &&
        RotationAngle(jump.rotation) * 180.0 / M_PI <= options_.max_rotation_from_seed_deg;
    e.agreement = Agreement(reference, current, e.cur_from_ref);
    e.verified = near_seed && e.agreement.inliers >= options_.constrained_min_inliers &&
                 e.agreement.inlier_fraction() >= options_.min_inlier_fraction;
  }
  e.time_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return e;
}

}  // namespace dygslam
