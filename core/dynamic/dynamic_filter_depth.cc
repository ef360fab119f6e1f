// Our extensions of the paper's filter (DynamicFilterOptions: depth_residual, box_depth_band,
// consensus_radius): a depth-residual test in place of the fundamental matrix, the split of each
// box into the object at its depth and the background behind it, and a depth-gated majority vote
// of neighbours. The paper's filter is dynamic_filter.cc.
#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/calib3d.hpp>

#include "core/dynamic/dynamic_filter.h"
#include "core/dynamic/dynamic_mask.h"

namespace dygslam {

void DynamicFilter::ObserveWithDepth(FrameStep* step, FilterResult* result) const {
  const DynamicFilterOptions& o = options_;
  const int n = static_cast<int>(step->matches.size());
  result->motion_model_ok = DepthResidual(
      step->input, step->geom, step->matches, result, &step->depth_distances, &step->depth_planar,
      &step->anchors, &step->cam_from_world_rotation, &step->cam_from_world_translation);
  for (int i = 0; i < n; ++i) {
    FeatureStatus& fs = result->features[i];
    const int j = step->matches[i];
    if (j < 0 || !(fs.in_dynamic_region || step->test_outside)) continue;
    const double prior_p =
        fs.in_dynamic_region && !fs.in_box_background ? step->region_prior : o.outside_p_init;
    const KalmanProbability prior_post = prev_states_[j].valid
                                             ? prev_states_[j].posterior
                                             : KalmanProbability{prior_p, o.initial_variance};
    if (result->motion_model_ok && step->depth_distances[i] >= 0) {
      fs.has_observation = true;
      fs.epipolar_distance = step->depth_distances[i];
      const double line_distance = step->depth_planar[i] && o.planar_residual_to_line
                                       ? step->depth_distances[i] / kPlanarToLineResidual
                                       : step->depth_distances[i];
      step->posterior[i] = KalmanUpdate(
          prior_post, GeometryProbability(line_distance / o.depth_residual_scale, o.c1, o.alpha),
          o.q, o.r);
    } else {
      step->posterior[i] = KalmanPredict(prior_post, o.q);
    }
    step->has_posterior[i] = 1;
  }
}

namespace {

cv::Vec3d BackProject(const cv::Matx33d& k, const cv::Point2f& p, double z) {
  return cv::Vec3d((p.x - k(0, 2)) * z / k(0, 0), (p.y - k(1, 2)) * z / k(1, 1), z);
}

// The fundamental matrix of a known motion cur_from_prev (rotation, translation) with camera k.
cv::Matx33d FundamentalOfMotion(const cv::Matx33d& k, const cv::Matx33d& rotation,
                                const cv::Vec3d& t) {
  const cv::Matx33d tx(0, -t[2], t[1], t[2], 0, -t[0], -t[1], t[0], 0);
  const cv::Matx33d k_inv = k.inv();
  return k_inv.t() * tx * rotation * k_inv;
}

// How far the anchor `x` (current camera) projects from the feature at `p`, in pixels; an anchor
// behind the camera reads as certainly moving.
double AnchorResidual(const cv::Matx33d& k, const cv::Vec3d& x, const cv::Point2f& p) {
  constexpr double kBehindCamera = 1e3;
  if (x[2] <= 1e-3) return kBehindCamera;
  const double du = k(0, 0) * x[0] / x[2] + k(0, 2) - p.x;
  const double dv = k(1, 1) * x[1] / x[2] + k(1, 2) - p.y;
  return std::hypot(du, dv);
}

}  // namespace

// Camera motion by PnP-RANSAC on matches whose previous feature has depth (or, world_anchors, an
// anchor), from the static region when it holds enough of them (full mode), else from all
// (geometry mode). False when there are too few or the solution is not well supported.
bool DynamicFilter::SolveFrameMotion(const FilterInput& input, const std::vector<cv::Point2f>& geom,
                                     const std::vector<int>& matches, FilterResult* result,
                                     cv::Matx33d* rotation, cv::Vec3d* translation) const {
  const DynamicFilterOptions& o = options_;
  const cv::Matx33d& k = *input.camera_matrix;
  const bool world = o.world_anchors;
  const int n = static_cast<int>(geom.size());
  if (prev_depths_.empty()) return false;
  std::vector<cv::Point3f> object;
  std::vector<cv::Point2f> image;
  for (int pass = 0; pass < 2 && static_cast<int>(object.size()) < o.pnp_min_inliers; ++pass) {
    object.clear();
    image.clear();
    for (int i = 0; i < n; ++i) {
      const int j = matches[i];
      if (j < 0) continue;
      if (world ? !prev_states_[j].has_anchor : prev_depths_[j] <= 0) continue;
      if (pass == 0 && result->features[i].in_dynamic_region &&
          !result->features[i].in_box_background)
        continue;
      const cv::Vec3d x =
          world ? prev_states_[j].anchor : BackProject(k, prev_geom_points_[j], prev_depths_[j]);
      object.emplace_back(static_cast<float>(x[0]), static_cast<float>(x[1]),
                          static_cast<float>(x[2]));
      image.push_back(geom[i]);
    }
  }
  result->num_pnp_matches = static_cast<int>(object.size());
  if (static_cast<int>(object.size()) >= o.pnp_min_inliers) {
    cv::Mat rvec, tvec;
    std::vector<int> inliers;
    bool found = false;
    try {
      found = cv::solvePnPRansac(object, image, cv::Mat(k), cv::noArray(), rvec, tvec, false,
                                 o.pnp_iterations, static_cast<float>(o.pnp_threshold), 0.99,
                                 inliers, cv::SOLVEPNP_ITERATIVE);
    } catch (const cv::Exception&) {
      found = false;
    }
    result->num_pnp_inliers = static_cast<int>(inliers.size());
    if (found && cv::checkRange(rvec) && cv::checkRange(tvec) &&
        result->num_pnp_inliers >= o.pnp_min_inliers &&
        result->num_pnp_inliers >= o.pnp_min_inlier_fraction * object.size()) {
      cv::Mat r;
      cv::Rodrigues(rvec, r);
      r.convertTo(r, CV_64F);
      tvec.convertTo(tvec, CV_64F);
      *rotation = cv::Matx33d(r);
      *translation = cv::Vec3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
      return true;
    }
  }
  return false;
}

bool DynamicFilter::DepthResidual(const FilterInput& input, const std::vector<cv::Point2f>& geom,
                                  const std::vector<int>& matches, FilterResult* result,
                                  std::vector<double>* distances, std::vector<uint8_t>* planar,
                                  std::vector<State>* anchors, cv::Matx33d* cam_from_world_rotation,
                                  cv::Vec3d* cam_from_world_translation) const {
  const DynamicFilterOptions& o = options_;
  const cv::Matx33d& k = *input.camera_matrix;
  const std::vector<float>& depths = *input.depths;
  const int n = static_cast<int>(geom.size());
  distances->assign(n, -1.0);
  planar->assign(n, 0);
  anchors->assign(n, State{});
  const auto back_project = [&](const cv::Point2f& p, double z) { return BackProject(k, p, z); };
  result->used_depth_residual = true;

  // Camera motion cur_from_prev: PnP-RANSAC on matches whose previous feature has depth, from
  // the static region when it holds enough of them (full mode), else from all (geometry mode).
  // world_anchors: cam_from_world by PnP on the matched tracks' anchors (fixed in the world).
  const bool world = o.world_anchors;
  const cv::Matx33d prev_r = *cam_from_world_rotation;
  const cv::Vec3d prev_t = *cam_from_world_translation;
  cv::Matx33d rotation = cv::Matx33d::eye();
  cv::Vec3d translation(0, 0, 0);
  const bool ok = SolveFrameMotion(input, geom, matches, result, &rotation, &translation);
  // Anchors are in `world` (world_anchors) or in the previous camera: `pose` maps them into the
  // current camera; `rotation` / `translation` become cur_from_prev.
  cv::Matx33d pose_r = rotation;
  cv::Vec3d pose_t = translation;
  if (world) {
    *cam_from_world_rotation = ok ? rotation : cv::Matx33d::eye();
    *cam_from_world_translation = ok ? translation : cv::Vec3d(0, 0, 0);
    if (ok) {
      rotation = pose_r * prev_r.t();
      translation = pose_t - rotation * prev_t;
    }
  }
  const cv::Matx33d world_from_cam_r = cam_from_world_rotation->t();
  const cv::Vec3d cam_from_world_t = *cam_from_world_translation;
  const auto to_anchor_frame = [&](const cv::Vec3d& x_cam) -> cv::Vec3d {
    return world ? cv::Vec3d(world_from_cam_r * (x_cam - cam_from_world_t)) : x_cam;
  };
  result->prev_rotation = rotation;
  result->prev_translation = translation;

  // Fundamental matrix of the estimated motion for features without an anchor (no depth).
  const cv::Matx33d fundamental =
      ok ? FundamentalOfMotion(k, rotation, translation) : cv::Matx33d::zeros();
  for (int i = 0; i < n; ++i) {
    const int j = matches[i];
    const double z = depths[i];
    State& a = (*anchors)[i];
    if (j >= 0 && ok) {
      const State& prev = prev_states_[j];
      if (prev.has_anchor) {
        const cv::Vec3d x = pose_r * prev.anchor + pose_t;
        const double d = AnchorResidual(k, x, geom[i]);
        // In units of the keypoint's pyramid scale (ORB keypoints are `31 * scale` px wide):
        // keypoints of coarse levels are localised less precisely.
        (*distances)[i] = d / std::max(1.0, input.keypoints[i].size / 31.0);
        (*planar)[i] = 1;
        result->features[i].track_age = prev.anchor_age + 1;
        if (prev.anchor_age + 1 < o.anchor_max_age) {
          a.has_anchor = true;
          a.anchor = world ? prev.anchor : x;
          a.anchor_age = prev.anchor_age + 1;
          continue;
        }
      } else if (cv::norm(translation) > 1e-9) {
        (*distances)[i] = EpipolarDistance(fundamental, prev_geom_points_[j], geom[i]);
      }
    }
    if (z > 0) {
      a.has_anchor = true;
      a.anchor = to_anchor_frame(back_project(geom[i], z));
      a.anchor_age = 0;
    }
  }
  return ok;
}

void DynamicFilter::SplitBoxesByDepth(const FilterInput& input, FilterResult* result) const {
  const DynamicFilterOptions& o = options_;
  const std::vector<float>& depths = *input.depths;
  const int n = static_cast<int>(depths.size());
  const bool use_image = input.depth_image != nullptr && !input.depth_image->empty() &&
                         input.depth_image->type() == CV_32FC1;
  std::vector<double> object(input.detections.size(), std::nan(""));
  for (size_t b = 0; b < input.detections.size(); ++b) {
    const cv::Rect2f& bf = input.detections[b].box;
    const cv::Rect box(
        cv::Point(static_cast<int>(std::floor(bf.x)), static_cast<int>(std::floor(bf.y))),
        cv::Point(static_cast<int>(std::ceil(bf.x + bf.width)),
                  static_cast<int>(std::ceil(bf.y + bf.height))));
    if (use_image) {
      object[b] = BoxObjectDepth(*input.depth_image, box);
    } else {
      // The keypoint depths inside the box, as a one-row depth image.
      std::vector<float> inside;
      for (int i = 0; i < n; ++i)
        if (depths[i] > 0 && box.contains(cv::Point(static_cast<int>(input.keypoints[i].pt.x),
                                                    static_cast<int>(input.keypoints[i].pt.y))))
          inside.push_back(depths[i]);
      if (!inside.empty()) {
        const cv::Mat row(1, static_cast<int>(inside.size()), CV_32FC1, inside.data());
        object[b] = BoxObjectDepth(row, cv::Rect(0, 0, row.cols, 1));
      }
    }
  }
  for (int i = 0; i < n; ++i) {
    FeatureStatus& fs = result->features[i];
    if (!fs.in_dynamic_region || depths[i] <= 0) continue;
    bool judged = false;
    for (size_t b = 0; b < input.detections.size(); ++b) {
      if (!std::isfinite(object[b])) continue;
      const cv::Rect2f r = DynamicRegion(input.detections[b], o);
      const cv::Point2f& p = input.keypoints[i].pt;
      if (!(p.x >= r.x && p.x <= r.x + r.width && p.y >= r.y && p.y <= r.y + r.height)) continue;
      judged = true;
      if (std::abs(depths[i] - object[b]) <= o.box_depth_band) fs.at_object_depth = true;
    }
    fs.in_box_background = judged && !fs.at_object_depth;
  }
}

void DynamicFilter::Consensus(const FilterInput& input, FilterResult* result) const {
  const DynamicFilterOptions& o = options_;
  const std::vector<cv::KeyPoint>& kps = input.keypoints;
  const std::vector<float>& depths = *input.depths;
  const int n = static_cast<int>(kps.size());
  // Features with depth in a grid of consensus_radius cells.
  const double cell = o.consensus_radius;
  std::unordered_map<int64_t, std::vector<int>> grid;
  // Shifted as unsigned: a negative cx << 32 is undefined in C++17 (UBSan); same bits.
  const auto key = [](int64_t cx, int64_t cy) {
    return static_cast<int64_t>((static_cast<uint64_t>(cx) << 32) ^
                                (static_cast<uint64_t>(cy) & 0xffffffffu));
  };
  for (int i = 0; i < n; ++i)
    if (depths[i] > 0)
      grid[key(static_cast<int64_t>(std::floor(kps[i].pt.x / cell)),
               static_cast<int64_t>(std::floor(kps[i].pt.y / cell)))]
          .push_back(i);
  const double r2 = o.consensus_radius * o.consensus_radius;
  std::vector<char> label(n);
  for (int i = 0; i < n; ++i) label[i] = result->features[i].is_dynamic;
  for (int i = 0; i < n; ++i) {
    // Features without depth, and the box's object itself, keep their label.
    if (depths[i] <= 0 || result->features[i].at_object_depth) continue;
    const int64_t cx = static_cast<int64_t>(std::floor(kps[i].pt.x / cell));
    const int64_t cy = static_cast<int64_t>(std::floor(kps[i].pt.y / cell));
    int near = 0, flagged = 0;
    for (int64_t gx = cx - 1; gx <= cx + 1; ++gx) {
      for (int64_t gy = cy - 1; gy <= cy + 1; ++gy) {
        const auto it = grid.find(key(gx, gy));
        if (it == grid.end()) continue;
        for (int j : it->second) {
          if (j == i) continue;
          const double dx = kps[j].pt.x - kps[i].pt.x, dy = kps[j].pt.y - kps[i].pt.y;
          if (dx * dx + dy * dy > r2 || std::abs(depths[j] - depths[i]) > o.consensus_depth_gap)
            continue;
          ++near;
          flagged += label[j];
        }
      }
    }
    if (near < o.consensus_min_neighbours) continue;
    const bool dynamic = 2 * (flagged + label[i]) > near + 1;
    FeatureStatus& fs = result->features[i];
    result->num_dynamic += static_cast<int>(dynamic) - static_cast<int>(fs.is_dynamic);
    fs.is_dynamic = dynamic;
  }
}

}  // namespace dygslam
