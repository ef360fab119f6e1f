#include "core/dynamic/dynamic_filter.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <unordered_map>

#include "core/base/popcount.h"
#include "core/dynamic/dynamic_mask.h"

namespace dygslam {

namespace {
struct ModeName {
  FilterMode mode;
  const char* name;
};
constexpr ModeName kModeNames[] = {{FilterMode::kNone, "none"},
                                   {FilterMode::kBoxes, "boxes"},
                                   {FilterMode::kGeometry, "geometry"},
                                   {FilterMode::kFull, "full"}};
}  // namespace

const char* ToString(FilterMode mode) {
  for (const ModeName& m : kModeNames)
    if (m.mode == mode) return m.name;
  return "unknown";
}

FilterMode ParseFilterMode(const std::string& text) {
  for (const ModeName& m : kModeNames)
    if (text == m.name) return m.mode;
  throw InvalidOptions("invalid filter mode '" + text + "': expected none|boxes|geometry|full");
}

bool UsesDetections(FilterMode mode) {
  return mode == FilterMode::kBoxes || mode == FilterMode::kFull;
}

void DynamicFilterOptions::Check() const {
  DYGSLAM_CHECK_OPTION(c1 > 0 && std::isfinite(c1), "DynamicFilter.c1");
  DYGSLAM_CHECK_OPTION(alpha >= -100 && alpha <= 100, "DynamicFilter.alpha");  // px
  DYGSLAM_CHECK_OPTION(q >= 0 && q <= 100, "DynamicFilter.q");
  DYGSLAM_CHECK_OPTION(r > 0 && std::isfinite(r), "DynamicFilter.r");
  DYGSLAM_CHECK_OPTION(p_init >= 0 && p_init <= 1, "DynamicFilter.p_init");
  DYGSLAM_CHECK_OPTION(c2 >= 0 && std::isfinite(c2), "DynamicFilter.c2");
  DYGSLAM_CHECK_OPTION(delta > 0 && std::isfinite(delta), "DynamicFilter.delta");
  DYGSLAM_CHECK_OPTION(threshold >= 0 && threshold <= 1, "DynamicFilter.threshold");
  DYGSLAM_CHECK_OPTION(initial_variance > 0 && std::isfinite(initial_variance),
                       "DynamicFilter.initial_variance");
  DYGSLAM_CHECK_OPTION(box_margin >= 0 && std::isfinite(box_margin), "DynamicFilter.box_margin");
  DYGSLAM_CHECK_OPTION(box_margin_fraction >= 0 && box_margin_fraction <= 1,
                       "DynamicFilter.box_margin_fraction");
  DYGSLAM_CHECK_OPTION(search_radius > 0 && search_radius <= 1000, "DynamicFilter.search_radius");
  DYGSLAM_CHECK_OPTION(max_hamming >= 0 && max_hamming <= 256, "DynamicFilter.max_hamming");
  DYGSLAM_CHECK_OPTION(ratio > 0 && ratio <= 1, "DynamicFilter.ratio");
  DYGSLAM_CHECK_OPTION(fundamental_threshold > 0 && std::isfinite(fundamental_threshold),
                       "DynamicFilter.fundamental_threshold");
  DYGSLAM_CHECK_OPTION(fundamental_confidence > 0 && fundamental_confidence < 1,
                       "DynamicFilter.fundamental_confidence");
  DYGSLAM_CHECK_OPTION(fundamental_max_iters > 0, "DynamicFilter.fundamental_max_iters");
  DYGSLAM_CHECK_OPTION(
      octave_scale_factor == 0 || (octave_scale_factor >= 1 && octave_scale_factor < 4),
      "DynamicFilter.octave_scale_factor");
  DYGSLAM_CHECK_OPTION(min_fundamental_matches >= 8, "DynamicFilter.min_fundamental_matches");
  DYGSLAM_CHECK_OPTION(homography_inlier_ratio > 0 && homography_inlier_ratio <= 2,
                       "DynamicFilter.homography_inlier_ratio");
  DYGSLAM_CHECK_OPTION(homography_threshold_scale > 0 && homography_threshold_scale <= 10,
                       "DynamicFilter.homography_threshold_scale");
  DYGSLAM_CHECK_OPTION(homography_dominant_fraction > 0 && homography_dominant_fraction <= 1,
                       "DynamicFilter.homography_dominant_fraction");

  DYGSLAM_CHECK_OPTION(depth_residual_scale > 0 && std::isfinite(depth_residual_scale),
                       "DynamicFilter.depth_residual_scale");
  DYGSLAM_CHECK_OPTION(anchor_max_age >= 1 && anchor_max_age <= 1000,
                       "DynamicFilter.anchor_max_age");
  DYGSLAM_CHECK_OPTION(pnp_threshold > 0 && std::isfinite(pnp_threshold),
                       "DynamicFilter.pnp_threshold");
  DYGSLAM_CHECK_OPTION(pnp_iterations > 0, "DynamicFilter.pnp_iterations");
  DYGSLAM_CHECK_OPTION(pnp_min_inliers >= 6, "DynamicFilter.pnp_min_inliers");
  DYGSLAM_CHECK_OPTION(pnp_min_inlier_fraction >= 0 && pnp_min_inlier_fraction <= 1,
                       "DynamicFilter.pnp_min_inlier_fraction");
  DYGSLAM_CHECK_OPTION(outside_p_init >= 0 && outside_p_init <= 1, "DynamicFilter.outside_p_init");
  DYGSLAM_CHECK_OPTION(std::isfinite(box_depth_band) && box_depth_band <= 10,
                       "DynamicFilter.box_depth_band");
  DYGSLAM_CHECK_OPTION(consensus_radius >= 0 && consensus_radius <= 200,
                       "DynamicFilter.consensus_radius");
  DYGSLAM_CHECK_OPTION(consensus_depth_gap > 0 && std::isfinite(consensus_depth_gap),
                       "DynamicFilter.consensus_depth_gap");
  DYGSLAM_CHECK_OPTION(consensus_min_neighbours >= 1 && consensus_min_neighbours <= 100,
                       "DynamicFilter.consensus_min_neighbours");
}

std::vector<uint8_t> FilterResult::DynamicFlags() const {
  std::vector<uint8_t> flags(features.size());
  for (size_t i = 0; i < features.size(); ++i) flags[i] = features[i].is_dynamic ? 1 : 0;
  return flags;
}

double EpipolarDistance(const cv::Matx33d& f, const cv::Point2d& p_prev, const cv::Point2d& p_t) {
  const cv::Vec3d line = f * cv::Vec3d(p_prev.x, p_prev.y, 1.0);  // eq. 3: l_t = F p_t-1
  const double norm = std::sqrt(line[0] * line[0] + line[1] * line[1]);
  if (norm < 1e-12) return std::numeric_limits<double>::infinity();
  return std::abs(line[0] * p_t.x + line[1] * p_t.y + line[2]) / norm;  // eq. 4
}

double GeometryProbability(double distance, double c1, double alpha) {
  return 1.0 / (1.0 + c1 * std::exp(-(distance - alpha)));  // eq. 5
}

KalmanProbability KalmanPredict(const KalmanProbability& previous_posterior, double q) {
  return {previous_posterior.p, previous_posterior.variance + q};  // eqs. 6-7
}

KalmanProbability KalmanUpdate(const KalmanProbability& previous_posterior, double observation,
                               double q, double r) {
  const KalmanProbability prior = KalmanPredict(previous_posterior, q);
  const double gain = prior.variance / (prior.variance + r);  // eq. 8
  return {prior.p + gain * (observation - prior.p),           // eq. 9 (standard update)
          (1.0 - gain) * prior.variance};                     // eq. 10
}

double ExpansionWeight(double distance, double c2, double delta) {
  return distance <= delta ? c2 * std::exp(-distance / delta) : 0.0;  // eq. 12
}

int HammingDistance256(const uint8_t* a, const uint8_t* b) {
  uint64_t x[4], y[4];
  std::memcpy(x, a, 32);
  std::memcpy(y, b, 32);
  return HammingDistance256Words(x, y);  // POPCNT when the CPU has it (core/base/popcount.h)
}

bool InAnyBox(const cv::Point2f& p, const std::vector<Detection>& detections,
              const DynamicFilterOptions& o) {
  for (const Detection& d : detections) {
    const cv::Rect2f r = DynamicRegion(d, o);
    if (p.x >= r.x && p.x <= r.x + r.width && p.y >= r.y && p.y <= r.y + r.height) return true;
  }
  return false;
}

cv::Rect2f DynamicRegion(const Detection& detection, const DynamicFilterOptions& options) {
  const float m =
      static_cast<float>(options.box_margin + options.box_margin_fraction * detection.box.width);
  return cv::Rect2f(detection.box.x - m, detection.box.y - m, detection.box.width + 2 * m,
                    detection.box.height + 2 * m);
}

DynamicFilter::DynamicFilter(const DynamicFilterOptions& options) : options_(options) {
  options_.Check();
}

void DynamicFilter::Reset() {
  has_prev_ = false;
  prev_points_.clear();
  prev_geom_points_.clear();
  prev_octaves_.clear();
  prev_descriptors_.release();
  prev_states_.clear();
  prev_depths_.clear();
  prev_cam_from_world_rotation_ = cv::Matx33d::eye();
  prev_cam_from_world_translation_ = cv::Vec3d(0, 0, 0);
}

namespace {

// Mutual best (each previous feature matched by the current feature it prefers); without it, the
// best current feature per previous feature (by Hamming distance `best_dist`).
void KeepOneMatchPerPrevious(bool mutual_best, const std::vector<int>& best_prev_cur,
                             const std::vector<int>& best_dist, std::vector<int>* matches) {
  const int n_cur = static_cast<int>(matches->size());
  if (mutual_best) {
    for (int i = 0; i < n_cur; ++i) {
      const int j = (*matches)[i];
      if (j >= 0 && best_prev_cur[j] != i) (*matches)[i] = -1;
    }
    return;
  }
  std::vector<int> owner(best_prev_cur.size(), -1);
  for (int i = 0; i < n_cur; ++i) {
    const int j = (*matches)[i];
    if (j < 0) continue;
    if (owner[j] < 0 || best_dist[i] < best_dist[owner[j]]) {
      if (owner[j] >= 0) (*matches)[owner[j]] = -1;
      owner[j] = i;
    } else {
      (*matches)[i] = -1;
    }
  }
}

}  // namespace

std::vector<int> DynamicFilter::MatchToPrevious(const std::vector<cv::KeyPoint>& keypoints,
                                                const cv::Mat& descriptors) const {
  const int n_cur = static_cast<int>(keypoints.size());
  const int n_prev = static_cast<int>(prev_points_.size());
  std::vector<int> matches(n_cur, -1);
  if (n_cur == 0 || n_prev == 0) return matches;

  // Grid over the previous frame with cells of search_radius: a window is at most 3x3 cells.
  const float cell = static_cast<float>(options_.search_radius);
  float max_x = 0, max_y = 0;
  for (const cv::Point2f& p : prev_points_) {
    max_x = std::max(max_x, p.x);
    max_y = std::max(max_y, p.y);
  }
  const int grid_w = static_cast<int>(max_x / cell) + 1,
            grid_h = static_cast<int>(max_y / cell) + 1;
  std::vector<int> cell_start(grid_w * grid_h + 1, 0), cell_items(n_prev);
  auto cell_of = [&](const cv::Point2f& p) {
    const int cx = std::clamp(static_cast<int>(p.x / cell), 0, grid_w - 1);
    const int cy = std::clamp(static_cast<int>(p.y / cell), 0, grid_h - 1);
    return cy * grid_w + cx;
  };
  for (const cv::Point2f& p : prev_points_) ++cell_start[cell_of(p) + 1];
  for (int c = 0; c < grid_w * grid_h; ++c) cell_start[c + 1] += cell_start[c];
  {
    std::vector<int> fill(cell_start.begin(), cell_start.end() - 1);
    for (int j = 0; j < n_prev; ++j) cell_items[fill[cell_of(prev_points_[j])]++] = j;
  }

  const float r2 = cell * cell;
  const int max_oct = options_.max_octave_difference;
  std::vector<int> best_prev_dist(n_prev, std::numeric_limits<int>::max());
  std::vector<int> best_prev_cur(n_prev, -1);
  std::vector<int> best_dist(n_cur, std::numeric_limits<int>::max());
  for (int i = 0; i < n_cur; ++i) {
    const cv::Point2f& p = keypoints[i].pt;
    const uint8_t* d_cur = descriptors.ptr<uint8_t>(i);
    const int cx = static_cast<int>(std::floor(p.x / cell)),
              cy = static_cast<int>(std::floor(p.y / cell));
    int best = std::numeric_limits<int>::max(), second = std::numeric_limits<int>::max(),
        best_j = -1;
    for (int gy = std::max(cy - 1, 0); gy <= std::min(cy + 1, grid_h - 1); ++gy) {
      for (int gx = std::max(cx - 1, 0); gx <= std::min(cx + 1, grid_w - 1); ++gx) {
        const int c = gy * grid_w + gx;
        for (int k = cell_start[c]; k < cell_start[c + 1]; ++k) {
          const int j = cell_items[k];
          const float dx = prev_points_[j].x - p.x, dy = prev_points_[j].y - p.y;
          if (dx * dx + dy * dy > r2) continue;
          if (max_oct >= 0 && std::abs(prev_octaves_[j] - keypoints[i].octave) > max_oct) continue;
          const int d = HammingDistance256(d_cur, prev_descriptors_.ptr<uint8_t>(j));
          if (d < best) {
            second = best;
            best = d;
            best_j = j;
          } else if (d < second) {
            second = d;
          }
          if (d < best_prev_dist[j]) {
            best_prev_dist[j] = d;
            best_prev_cur[j] = i;
          }
        }
      }
    }
    if (best_j < 0 || best > options_.max_hamming) continue;
    if (second != std::numeric_limits<int>::max() && best >= options_.ratio * second) continue;
    matches[i] = best_j;
    best_dist[i] = best;
  }
  KeepOneMatchPerPrevious(options_.mutual_best, best_prev_cur, best_dist, &matches);
  return matches;
}

namespace {

// Each feature's match in the previous frame, and the counts of matches (in the dynamic region).
void RecordMatches(const std::vector<int>& matches, FilterResult* result) {
  for (size_t i = 0; i < matches.size(); ++i) {
    if (matches[i] < 0) continue;
    result->features[i].prev_match = matches[i];
    ++result->num_matched;
    result->num_matched_dynamic_region += result->features[i].in_dynamic_region;
  }
}

void CheckFilterInput(const FilterInput& input) {
  const int n = static_cast<int>(input.keypoints.size());
  if (input.descriptors.rows != n)
    throw InputError("DynamicFilter::Process: " + std::to_string(input.descriptors.rows) +
                     " descriptor rows for " + std::to_string(n) + " keypoints");
  if (n > 0 && (input.descriptors.type() != CV_8UC1 || input.descriptors.cols != 32))
    throw InputError("DynamicFilter::Process: descriptors must be CV_8UC1 N x 32 (ORB)");
  if (input.undistorted_points != nullptr &&
      static_cast<int>(input.undistorted_points->size()) != n)
    throw InputError("DynamicFilter::Process: undistorted_points size differs from keypoints");
}

// F by GC-RANSAC (OpenCV's USAC_ACCURATE) on the matches; false when none could be fitted.
bool FitFundamental(const std::vector<cv::Point2f>& prev, const std::vector<cv::Point2f>& cur,
                    const DynamicFilterOptions& o, cv::Matx33d* fundamental, FilterResult* result) {
  cv::Mat f;
  try {
    f = cv::findFundamentalMat(prev, cur, cv::USAC_ACCURATE, o.fundamental_threshold,
                               o.fundamental_confidence, o.fundamental_max_iters, cv::noArray());
  } catch (const cv::Exception&) {
    f.release();
  }
  if (f.rows != 3 || f.cols != 3) return false;
  f.convertTo(f, CV_64F);
  if (!cv::checkRange(f) || cv::norm(f) <= 0) return false;
  *fundamental = cv::Matx33d(f);
  result->fundamental = f;
  // Inliers under eq. 4 (one-sided distance).
  int inliers = 0;
  for (size_t k = 0; k < prev.size(); ++k)
    inliers += EpipolarDistance(*fundamental, prev[k], cur[k]) <= o.fundamental_threshold;
  result->num_f_inliers = inliers;
  return true;
}

// A homography by USAC_ACCURATE and its inliers within `threshold` (transfer error); -1 when none
// could be fitted.
int FitHomography(const std::vector<cv::Point2f>& prev, const std::vector<cv::Point2f>& cur,
                  const DynamicFilterOptions& o, double threshold, cv::Matx33d* homography) {
  cv::Mat h;
  try {
    h = cv::findHomography(prev, cur, cv::USAC_ACCURATE, threshold, cv::noArray(),
                           o.fundamental_max_iters, o.fundamental_confidence);
  } catch (const cv::Exception&) {
    h.release();
  }
  if (h.rows != 3 || h.cols != 3 || !cv::checkRange(h)) return -1;
  h.convertTo(h, CV_64F);
  *homography = cv::Matx33d(h);
  int inliers = 0;
  for (size_t k = 0; k < prev.size(); ++k) {
    const cv::Vec3d x = *homography * cv::Vec3d(prev[k].x, prev[k].y, 1.0);
    if (std::abs(x[2]) < 1e-12) continue;
    inliers += std::hypot(x[0] / x[2] - cur[k].x, x[1] / x[2] - cur[k].y) <= threshold;
  }
  return inliers;
}

}  // namespace

FilterResult DynamicFilter::Process(const FilterInput& input) {
  using Clock = std::chrono::steady_clock;
  const auto ms_since = [](Clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  };
  CheckFilterInput(input);
  const std::vector<cv::KeyPoint>& kps = input.keypoints;
  const int n = static_cast<int>(kps.size());
  const DynamicFilterOptions& o = options_;
  FilterResult result;
  result.num_features = n;
  result.features.resize(n);
  if (o.mode == FilterMode::kNone) return result;

  for (int i = 0; i < n; ++i) {
    FeatureStatus& f = result.features[i];
    f.in_dynamic_region =
        o.mode == FilterMode::kGeometry || InAnyBox(kps[i].pt, input.detections, o);
    result.num_in_dynamic_region += f.in_dynamic_region;
  }
  FrameStep step(input);
  step.depth_mode = o.depth_residual &&
                    (o.mode == FilterMode::kGeometry || o.mode == FilterMode::kFull) &&
                    input.depths != nullptr && input.camera_matrix != nullptr &&
                    static_cast<int>(input.depths->size()) == n;
  if (step.depth_mode && o.mode == FilterMode::kFull && o.box_depth_band > 0 &&
      !input.detections.empty())
    SplitBoxesByDepth(input, &result);
  if (o.mode == FilterMode::kBoxes) {
    for (FeatureStatus& f : result.features) {
      f.probability = f.in_dynamic_region ? 1.0 : 0.0;
      f.is_dynamic = f.in_dynamic_region;
      result.num_dynamic += f.is_dynamic;
    }
    return result;
  }
  step.geom.resize(n);
  for (int i = 0; i < n; ++i)
    step.geom[i] = input.undistorted_points ? (*input.undistorted_points)[i] : kps[i].pt;

  // b. Matching to the previous frame.
  auto t0 = Clock::now();
  step.matches = has_prev_ ? MatchToPrevious(kps, input.descriptors) : std::vector<int>(n, -1);
  result.matching_ms = ms_since(t0);

  t0 = Clock::now();
  step.posterior.resize(n);
  step.has_posterior.assign(n, 0);
  // Ours: the depth-residual test replaces F (see DynamicFilterOptions::depth_residual), in
  // geometry and full mode (the keyframe masks no longer depend on the in-box labels, so the
  // ghost-voxel figure holds: BENCHMARKS.md, *Map quality: ghost voxels*).
  step.test_outside = step.depth_mode && o.mode == FilterMode::kFull;
  // Prior of a new track in the dynamic region: p_init inside a box; without boxes (geometry
  // mode) the depth-residual test has no reason to presume a feature moving: outside_p_init.
  step.region_prior =
      step.depth_mode && o.mode == FilterMode::kGeometry ? o.outside_p_init : o.p_init;
  step.cam_from_world_rotation = prev_cam_from_world_rotation_;
  step.cam_from_world_translation = prev_cam_from_world_translation_;
  if (step.depth_mode && !has_prev_) {
    const std::vector<int> no_matches(n, -1);
    DepthResidual(input, step.geom, no_matches, &result, &step.depth_distances, &step.depth_planar,
                  &step.anchors, &step.cam_from_world_rotation, &step.cam_from_world_translation);
  }
  if (has_prev_) {
    RecordMatches(step.matches, &result);
    if (step.depth_mode) {
      ObserveWithDepth(&step, &result);
    } else {
      ObserveEpipolar(&step, &result);
    }
  }
  std::vector<State> states = ExpandAndDecide(step, &result);
  if (step.depth_mode && o.consensus_radius > 0 && has_prev_) Consensus(input, &result);
  result.probability_ms = ms_since(t0);
  Remember(&step, std::move(states));
  return result;
}

DynamicFilter::MotionModel DynamicFilter::FitMotionModel(const std::vector<cv::Point2f>& prev,
                                                         const std::vector<cv::Point2f>& cur,
                                                         FilterResult* result) const {
  const DynamicFilterOptions& o = options_;
  MotionModel model;
  if (static_cast<int>(prev.size()) < o.min_fundamental_matches) return model;
  model.fundamental_ok = FitFundamental(prev, cur, o, &model.fundamental, result);
  if (!o.use_homography_for_degenerate) return model;
  // Degenerate motion check: does a homography explain the matches as well as F?
  // The transfer error is 2-D, the epipolar distance 1-D: for the same Gaussian noise the
  // same inlier probability (95 %) needs a threshold 2.45 / 1.96 = 1.25 times larger.
  cv::Matx33d h;
  const int h_inliers =
      FitHomography(prev, cur, o, o.homography_threshold_scale * o.fundamental_threshold, &h);
  if (h_inliers < 0) return model;
  result->num_h_inliers = h_inliers;
  // H replaces F when it explains the matches as well as F, or, when F had to be fitted on all
  // matches (moving objects included: with the small baseline of consecutive frames a 7-dof F
  // absorbs a rigidly moving object), when H explains most matches.
  const bool as_good_as_f =
      !model.fundamental_ok || h_inliers >= o.homography_inlier_ratio * result->num_f_inliers;
  const bool dominant_in_contaminated =
      result->used_all_matches_for_f &&
      h_inliers >= o.homography_dominant_fraction * static_cast<double>(prev.size());
  if (h_inliers >= o.min_fundamental_matches && (as_good_as_f || dominant_in_contaminated)) {
    result->used_homography = true;
    model.use_homography = true;
    model.homography = h;
  }
  return model;
}

void DynamicFilter::ObserveEpipolar(FrameStep* step, FilterResult* result) const {
  const DynamicFilterOptions& o = options_;
  const int n = static_cast<int>(step->matches.size());
  std::vector<cv::Point2f> prev_static, cur_static, prev_all, cur_all;
  for (int i = 0; i < n; ++i) {
    const int j = step->matches[i];
    if (j < 0) continue;
    prev_all.push_back(prev_geom_points_[j]);
    cur_all.push_back(step->geom[i]);
    if (!result->features[i].in_dynamic_region) {
      prev_static.push_back(prev_geom_points_[j]);
      cur_static.push_back(step->geom[i]);
    }
  }
  // c. Fundamental matrix from the static region (GC-RANSAC).
  result->used_all_matches_for_f = static_cast<int>(prev_static.size()) < o.min_fundamental_matches;
  const auto& f_prev = result->used_all_matches_for_f ? prev_all : prev_static;
  const auto& f_cur = result->used_all_matches_for_f ? cur_all : cur_static;
  result->num_static_matches_used_for_f = static_cast<int>(f_prev.size());
  const MotionModel model = FitMotionModel(f_prev, f_cur, result);
  result->motion_model_ok = model.fundamental_ok || model.use_homography;
  // d + e. Observation and Kalman update for matched dynamic-region features.
  for (int i = 0; i < n; ++i) {
    FeatureStatus& fs = result->features[i];
    const int j = step->matches[i];
    if (!fs.in_dynamic_region || j < 0) continue;
    const KalmanProbability prior_post = prev_states_[j].valid
                                             ? prev_states_[j].posterior
                                             : KalmanProbability{o.p_init, o.initial_variance};
    step->has_posterior[i] = 1;
    if (!result->motion_model_ok) {
      step->posterior[i] = KalmanPredict(prior_post, o.q);
      continue;
    }
    const cv::Point2f& p = prev_geom_points_[j];
    const cv::Point2f& c = step->geom[i];
    double d;
    if (model.use_homography) {
      const cv::Vec3d x = model.homography * cv::Vec3d(p.x, p.y, 1.0);
      d = std::abs(x[2]) < 1e-12 ? std::numeric_limits<double>::infinity()
                                 : std::hypot(x[0] / x[2] - c.x, x[1] / x[2] - c.y);
    } else {
      d = EpipolarDistance(model.fundamental, p, c);
    }
    fs.has_observation = true;
    fs.epipolar_distance = d;
    // Optional: distances in units of the keypoint's pyramid scale (localisation error grows
    // with the octave). Off by default (the paper uses pixels).
    const int octave = std::max(step->input.keypoints[i].octave, 0);
    const double d_eff =
        o.octave_scale_factor > 1.0 ? d / std::pow(o.octave_scale_factor, octave) : d;
    step->posterior[i] =
        KalmanUpdate(prior_post, GeometryProbability(d_eff, o.c1, o.alpha), o.q, o.r);
  }
}

// Eqs. 11-12 from `sources` to feature i (depth-gated in depth mode), starting from `base`.
double DynamicFilter::Expand(const FrameStep& step, int i, double base,
                             const std::vector<int>& sources) const {
  const DynamicFilterOptions& o = options_;
  const std::vector<cv::KeyPoint>& kps = step.input.keypoints;
  const double delta2 = o.delta * o.delta;
  double weight_sum = 0, change = 0;
  for (int m : sources) {
    const double dx = kps[m].pt.x - kps[i].pt.x, dy = kps[m].pt.y - kps[i].pt.y;
    const double d2 = dx * dx + dy * dy;
    if (d2 > delta2) continue;
    if (step.depth_mode && o.expansion_depth_gap > 0) {
      const float zi = (*step.input.depths)[i], zm = (*step.input.depths)[m];
      if (zi > 0 && zm > 0 && std::abs(zi - zm) > o.expansion_depth_gap) continue;
    }
    const double w = ExpansionWeight(std::sqrt(d2), o.c2, o.delta);
    weight_sum += w;
    change += w * (step.posterior[m].p - base);
  }
  // Eq. 11 sums without normalising (the paper; clamped below). Ours (depth mode): a weighted
  // mean once the weights exceed 1, so many static neighbours cannot add up to a certainty.
  return std::clamp(base + (step.depth_mode && weight_sum > 1 ? change / weight_sum : change), 0.0,
                    1.0);
}

std::vector<DynamicFilter::State> DynamicFilter::ExpandAndDecide(const FrameStep& step,
                                                                 FilterResult* result) const {
  const DynamicFilterOptions& o = options_;
  const int n = static_cast<int>(result->features.size());
  // f. Expansion to unmatched dynamic-region features (eqs. 11-12).
  std::vector<int> matched_dyn, matched_outside;
  for (int i = 0; i < n; ++i) {
    if (!step.has_posterior[i]) continue;
    (result->features[i].in_dynamic_region ? matched_dyn : matched_outside).push_back(i);
  }
  std::vector<State> states(n);
  for (int i = 0; i < n; ++i) {
    FeatureStatus& fs = result->features[i];
    if (!fs.in_dynamic_region) {
      // Depth-residual test outside the boxes (full mode): matched tracks carry their state.
      if (step.has_posterior[i]) {
        fs.probability = step.posterior[i].p;
        states[i] = {true, step.posterior[i]};
      } else if (step.test_outside && o.expand_outside && has_prev_) {
        // expand_outside: an unmatched feature outside the boxes inherits from its matched
        // neighbours outside the boxes, and its track starts from that (as in geometry mode).
        fs.probability = Expand(step, i, o.outside_p_init, matched_outside);
        states[i] = {true, {fs.probability, o.initial_variance}};
      } else {
        continue;
      }
      fs.is_dynamic = fs.probability > o.threshold;
      result->num_dynamic += fs.is_dynamic;
      continue;
    }
    if (step.has_posterior[i]) {
      fs.probability = step.posterior[i].p;
      states[i] = {true, step.posterior[i]};
    } else {
      const double base = fs.in_box_background ? o.outside_p_init : step.region_prior;
      fs.probability = Expand(step, i, base, matched_dyn);
      states[i] = {true, {fs.probability, o.initial_variance}};
    }
    // g. Decision. Geometry mode has no information on the first frame: keep everything.
    const bool informed = has_prev_ || o.mode == FilterMode::kFull;
    fs.is_dynamic = informed && (fs.probability > o.threshold || fs.at_object_depth);
    result->num_dynamic += fs.is_dynamic;
  }
  return states;
}

void DynamicFilter::Remember(FrameStep* step, std::vector<State> states) {
  const FilterInput& input = step->input;
  const int n = static_cast<int>(input.keypoints.size());
  if (step->depth_mode) {
    for (int i = 0; i < n; ++i) {
      states[i].has_anchor = step->anchors[i].has_anchor;
      states[i].anchor = step->anchors[i].anchor;
      states[i].anchor_age = step->anchors[i].anchor_age;
    }
    prev_depths_ = *input.depths;
    prev_cam_from_world_rotation_ = step->cam_from_world_rotation;
    prev_cam_from_world_translation_ = step->cam_from_world_translation;
  } else {
    prev_depths_.clear();
  }
  has_prev_ = true;
  prev_points_.resize(n);
  prev_octaves_.resize(n);
  for (int i = 0; i < n; ++i) {
    prev_points_[i] = input.keypoints[i].pt;
    prev_octaves_[i] = input.keypoints[i].octave;
  }
  prev_geom_points_ = std::move(step->geom);
  input.descriptors.copyTo(prev_descriptors_);
  prev_states_ = std::move(states);
}

}  // namespace dygslam
