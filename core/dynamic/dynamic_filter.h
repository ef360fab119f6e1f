// The dynamic-feature filter of DYG-SLAM (paper sec. 2): detector boxes split the features into a
// static and a dynamic region; features are matched to the previous frame; a fundamental matrix
// is estimated from static-region matches with GC-RANSAC (cv::USAC_ACCURATE); every matched
// dynamic-region feature gets a geometry probability from its epipolar distance (eqs. 4-5), fused
// over frames with a scalar Kalman filter carried through the matches (eqs. 6-10); the
// probability is spread to unmatched dynamic-region features (eqs. 11-12); features with
// probability > threshold are dynamic and are dropped before tracking.
//
//   DynamicFilter filter(options);
//   FilterResult r = filter.Process(FilterInput(keypoints, descriptors, detections));
//   for (size_t i = 0; i < keypoints.size(); ++i) if (!r.features[i].is_dynamic) keep(i);
//
// Choices the paper leaves open (documented here, options in DynamicFilterOptions):
// - Matching: consecutive frames only, candidates within `search_radius` px of the same position
//   (grid lookup), |octave difference| <= max_octave_difference, Hamming <= max_hamming, Lowe
//   ratio, mutual best.
// - Kalman initialisation: a matched feature whose previous feature carried no state starts
//   from P+ = p_init, Q+ = initial_variance. The update is the standard
//   P+ = P- + K (z - P-) (eq. 9 of the paper text is a typesetting error).
// - State carried to the next frame: every dynamic-region feature (matched: its Kalman
//   posterior; unmatched: its expanded probability with variance initial_variance).
//   Static-region features carry no state.
// - Expansion (eq. 11): the sum is over matched dynamic-region features within delta; it is not
//   normalised, so the result is clamped to [0, 1].
// - Too few static matches for F (< min_fundamental_matches): F is estimated from all matches
//   (the moving object then takes part, GC-RANSAC still treats it as outliers when it is the
//   minority); if there are still too few, or neither F nor H can be estimated, there is no
//   observation: the matched features only run the prediction step (P- kept, variance grows)
//   and `result.motion_model_ok` is false.
// - Degenerate motion (camera (nearly) not translating, or a planar scene): when a homography
//   explains the static matches as well as F (>= homography_inlier_ratio of F's inliers), the
//   epipolar distance is meaningless (any epipole fits) and the transfer distance |p_t - H p_t-1|
//   replaces eq. 4. When F had to be fitted on all matches (geometry mode, fallback), a rigidly
//   moving object is absorbed by the 7-dof F at the small baseline of consecutive frames (seen
//   on generated data: movers at 0.35 px from F); then H is used when it explains at least
//   homography_dominant_fraction of the matches. Disable with use_homography_for_degenerate.
// - First frame (no previous frame): full/boxes: dynamic-region features get p_init (so they are
//   dynamic with the paper's p_init = 0.6 > 0.5); geometry mode: nothing is marked dynamic.
//
// Coordinates: `keypoints` are in the (distorted) image in which the boxes were detected; they
// are used for the region test, matching and expansion distances. If `undistorted_points` is
// given (same size), it is used for F and the epipolar distances (recommended with lens
// distortion); otherwise the keypoint positions are used.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/base/types.h"

namespace dygslam {

// The filter mode, the one enum of the project (`--filter`, settings `DynamicFilter.mode`,
// SystemOptions::filter.mode).
enum class FilterMode {
  kNone,      // nothing removed
  kBoxes,     // every feature inside a dynamic box removed (Crowd-SLAM-like)
  kGeometry,  // no detector: the whole image is the dynamic region, F from all matches
  kFull,      // the paper: boxes + geometry probability + Kalman + expansion
};
const char* ToString(FilterMode mode);
// "none" | "boxes" | "geometry" | "full"; throws InvalidOptions otherwise.
FilterMode ParseFilterMode(const std::string& text);
// The modes that need person boxes (a detector): boxes, full.
bool UsesDetections(FilterMode mode);

// Eq. 5's alpha and C1 were set for eq. 4, the distance of a point to its epipolar line: one
// component of the localisation noise. The depth-residual test (ours) measures the distance of a
// feature to where its anchor projects: both components. With the same noise per axis the 2-D
// distance is larger, in median by sqrt(2 ln 2) / 0.67449 (the medians of a Rayleigh and of a
// half-normal variable of the same sigma): an anchor's residual is divided by this before eq. 5.
// Measured (docs/how_it_works.md): the median anchor residual of the features outside the person
// boxes is 1.35 alpha on the generated sequences and 1.63 alpha on bonn_crowd_part frames 0-110;
// without the conversion eq. 5 reads most of a blurred frame's static features as moving.
inline constexpr double kPlanarToLineResidual = 1.1774100225154747 / 0.6744897501960817;

struct DynamicFilterOptions {
  FilterMode mode = FilterMode::kFull;

  // Paper parameters (sec. 3): C1, alpha, Q, R, P_init, C2, delta and the 0.5 threshold.
  double c1 = 2.0;
  double alpha = 0.4;  // px
  double q = 0.09;     // state-transition variance
  double r = 1.0;      // observation variance
  double p_init = 0.6;
  double c2 = 1.0;
  double delta = 60.0;  // px
  double threshold = 0.5;
  // > 1: the epipolar distance enters eq. 5 divided by octave_scale_factor^octave (keypoints of
  // coarse pyramid levels are localised less precisely). 0: plain pixels, as in the paper.
  double octave_scale_factor = 0.0;
  // Posterior variance of a feature first seen in the dynamic region (no prior state).
  double initial_variance = 1.0;

  // Boxes are grown by this many pixels on each side for the region test.
  double box_margin = 0.0;
  // Plus this fraction of the box width on each side: detector boxes are imprecise in proportion
  // to their size (arms and legs stick out of people's boxes).
  double box_margin_fraction = 0.1;

  // Matching to the previous frame.
  double search_radius = 48.0;  // px
  int max_hamming = 50;         // bits (of 256)
  double ratio = 0.8;           // best < ratio * second best (within the window)
  bool mutual_best = true;
  int max_octave_difference = 1;  // < 0: no octave constraint

  // Fundamental matrix (cv::findFundamentalMat with cv::USAC_ACCURATE = GC-RANSAC).
  double fundamental_threshold = 1.0;  // px (epipolar distance)
  double fundamental_confidence = 0.99;
  int fundamental_max_iters = 1000;
  int min_fundamental_matches = 15;
  bool use_homography_for_degenerate = true;
  double homography_inlier_ratio = 0.95;
  // Inlier threshold of H (transfer error, px) = this x fundamental_threshold.
  double homography_threshold_scale = 1.25;
  // When F is fitted on all matches (geometry mode, or too few static matches), H is used when
  // its inliers are at least this fraction of the matches.
  double homography_dominant_fraction = 0.6;

  // Ours (not in the paper; off in the `paper` configurations): the depth-residual test. With
  // per-keypoint depth and the camera matrix in FilterInput, the camera motion from the previous
  // frame is estimated by PnP-RANSAC on matches with depth (static-region matches first) and
  // replaces F: each matched feature carries a 3-D anchor (its back-projection when its track
  // started, moved along by the estimated camera motion) and its observation is the residual
  // (px, divided by the keypoint's pyramid scale) between the anchor projected into frame t and
  // the feature (a depth term was measured worse: Bonn's depth noise outweighs what it adds:
  // geometry mode 0.063 m ATE without it, 0.188 m with 0.25 x fx |z_pred - z| / z). A static point
  // stays at ~1 px however long the track; a mover's residual grows with the track's age (the
  // baseline grows: a slow walker at 30 Hz moves a few px per frame, tens of px over anchor_max_age
  // frames). Features without depth get the epipolar distance under the estimated motion (E = [t]x
  // R). When the motion cannot be estimated (too few matches with depth, or inliers below
  // pnp_min_inliers / pnp_min_inlier_fraction) the filter abstains: prediction only. In full mode
  // the features outside the boxes are tested too (a new track there starts from outside_p_init),
  // so an undetected mover can be caught.
  bool depth_residual = true;
  // Ours: an anchor's 2-D residual is divided by kPlanarToLineResidual before eq. 5 (false: it
  // enters as measured, as eq. 4's 1-D distance would).
  bool planar_residual_to_line = true;
  // The residual enters eq. 5 divided by this (px), on top of planar_residual_to_line.
  double depth_residual_scale = 1.0;
  int anchor_max_age = 10;  // frames; then the anchor restarts from the measurement
  // Ours: anchors fixed in the filter's own odometry frame (set where their track
  // started or restarted, never moved), and the camera pose estimated by PnP against them, so a
  // mover's anchors drift off by its whole motion since then (several px after a few frames)
  // and cannot be absorbed by the motion estimate; false: anchors in the previous camera frame,
  // moved along by the chained frame-to-frame motion (a walker at 1-2 px per frame biases it).
  bool world_anchors = true;
  double pnp_threshold = 2.0;  // px, RANSAC inlier threshold
  int pnp_iterations = 100;
  int pnp_min_inliers = 20;
  double pnp_min_inlier_fraction = 0.3;
  double outside_p_init = 0.2;  // prior of a new track outside the boxes (full mode)
  // Expansion (eq. 11) with depth: only from matched features whose depth differs by at most
  // this (metres) when both have depth, so a wall behind a person does not inherit the
  // person's probability. <= 0: off.
  double expansion_depth_gap = 0.3;
  // Ours (0 in the `paper` configurations): depth-refined boxes. In full mode with the
  // depth-residual test, each box's object depth is estimated (BoxObjectDepth of
  // core/dynamic/dynamic_mask.h: the nearest depth band holding a fair share of the box's depth
  // pixels, from FilterInput::depth_image, else from the keypoint depths in the box); an in-box
  // feature whose depth is within box_depth_band of it is the object (dynamic, moving or
  // standing); an in-box feature clearly off that depth is background and is judged like a
  // feature outside the boxes (prior outside_p_init, the depth-residual test). In-box features
  // without depth keep the paper's rule. <= 0: off (every in-box feature starts from p_init).
  double box_depth_band = 0.4;  // m
  // Ours (0 in the `paper` configurations, which run without the depth-residual
  // test): neighbour consensus. With the depth-residual test, a feature's label becomes the
  // majority of itself and the features within consensus_radius px whose depth is within
  // consensus_depth_gap m of its own, when it has at least consensus_min_neighbours of them (a
  // person is a depth-connected blob: isolated flags on static features are dropped, a mover's
  // unflagged features join their flagged neighbours). In-box features at their box's object
  // depth stay dynamic. Measured on generated sequences (BENCHMARKS.md): radius 90
  // px takes full's precision from 0.84 to 0.99 (walkers) and 0.72 to 0.96 (near). <= 0: off.
  double consensus_radius = 90.0;    // px
  double consensus_depth_gap = 0.3;  // m
  int consensus_min_neighbours = 3;
  // Ours: in full mode with the depth-residual test, unmatched features
  // outside the boxes get the expansion (eqs. 11-12, from outside_p_init) from their matched
  // neighbours outside the boxes and carry it as their track's prior, as every feature does in
  // geometry mode. Without it a new track on a mover no box reports starts again from
  // outside_p_init (measured: undetected-mover recall 0.50 without, 0.99 with).
  bool expand_outside = true;

  void Check() const;
};

// Non-owning view of one frame's features; valid for the duration of Process().
struct FilterInput {
  FilterInput(const std::vector<cv::KeyPoint>& keypoints_in, const cv::Mat& descriptors_in,
              const std::vector<Detection>& detections_in)
      : keypoints(keypoints_in), descriptors(descriptors_in), detections(detections_in) {}
  const std::vector<cv::KeyPoint>& keypoints;  // level-0 pixel coordinates
  const cv::Mat& descriptors;                  // CV_8UC1, N x 32 (ORB)
  const std::vector<Detection>& detections;    // dynamic-object boxes (all treated as dynamic)
  // Optional, same size as keypoints: undistorted positions for F / epipolar distances.
  const std::vector<cv::Point2f>* undistorted_points = nullptr;
  // Optional (depth-residual test, see DynamicFilterOptions::depth_residual): depth in metres of
  // each keypoint (<= 0: none) and the camera matrix of the undistorted points.
  const std::vector<float>* depths = nullptr;
  const cv::Matx33d* camera_matrix = nullptr;
  // Optional (box_depth_band): the depth image, CV_32FC1 metres, in the keypoints' pixel grid.
  const cv::Mat* depth_image = nullptr;
};

struct FeatureStatus {
  bool in_dynamic_region = false;
  // box_depth_band: in a box and at its object's depth (the object itself); in a box but clearly
  // off that depth (background, judged like a feature outside the boxes).
  bool at_object_depth = false;
  bool in_box_background = false;
  int prev_match = -1;            // index of the matched feature in the previous frame, -1 if none
  bool has_observation = false;   // an epipolar observation z was computed (eqs. 4-5)
  int track_age = 0;              // depth-residual test: frames since the anchor was set
  double epipolar_distance = -1;  // px, eq. 4 (or homography transfer distance), -1 if none
  double probability = 0;         // final geometry probability (0 for static-region features)
  bool is_dynamic = false;
  bool matched() const { return prev_match >= 0; }
};

struct FilterResult {
  std::vector<FeatureStatus> features;
  int num_features = 0;
  int num_in_dynamic_region = 0;
  int num_matched = 0;  // all matches to the previous frame
  int num_matched_dynamic_region = 0;
  int num_static_matches_used_for_f = 0;
  int num_f_inliers = 0;  // under eq. 4 with fundamental_threshold
  int num_h_inliers = 0;  // transfer error <= homography_threshold_scale x fundamental_threshold
  // A motion model (F, or H for degenerate motion) was estimated; false: prediction only.
  bool motion_model_ok = false;
  bool used_homography = false;  // degenerate motion: transfer distance instead of eq. 4
  bool used_all_matches_for_f = false;
  // Depth-residual test: it ran (depths given, option on), and the camera motion was estimated.
  bool used_depth_residual = false;
  int num_pnp_matches = 0;
  int num_pnp_inliers = 0;
  cv::Matx33d prev_rotation = cv::Matx33d::eye();  // cur_from_prev (when motion_model_ok)
  cv::Vec3d prev_translation = cv::Vec3d(0, 0, 0);
  int num_dynamic = 0;
  cv::Mat fundamental;  // 3x3 CV_64F (p_t^T F p_t-1 = 0), empty if none
  double matching_ms = 0;
  double probability_ms = 0;  // F estimation + epipolar probability + Kalman + expansion
  // Per-feature flags in the layout of KeyframeData::keypoint_dynamic.
  std::vector<uint8_t> DynamicFlags() const;
};

// The dynamic region of one detection: its box grown by box_margin + box_margin_fraction * width.
cv::Rect2f DynamicRegion(const Detection& detection, const DynamicFilterOptions& options);

// Eq. 4: distance (px) of p_t to the epipolar line F p_prev (p_t^T F p_prev = 0).
double EpipolarDistance(const cv::Matx33d& fundamental, const cv::Point2d& p_prev,
                        const cv::Point2d& p_t);
// Eq. 5: 1 / (1 + c1 exp(-(d - alpha))).
double GeometryProbability(double distance, double c1, double alpha);

// One step of the scalar Kalman filter of eqs. 6-10.
struct KalmanProbability {
  double p = 0;  // posterior probability
  double variance = 0;
};
KalmanProbability KalmanUpdate(const KalmanProbability& previous_posterior, double observation,
                               double q, double r);
KalmanProbability KalmanPredict(const KalmanProbability& previous_posterior, double q);
// Eq. 12.
double ExpansionWeight(double distance, double c2, double delta);

// Hamming distance of two 32-byte ORB descriptors.
int HammingDistance256(const uint8_t* a, const uint8_t* b);

class DynamicFilter {
 public:
  explicit DynamicFilter(const DynamicFilterOptions& options);

  // Classifies the features of frame t and remembers them as the previous frame for t+1.
  // Throws InputError when descriptors and keypoints disagree (rows, type, 32 bytes).
  FilterResult Process(const FilterInput& input);
  // Forget the previous frame (e.g. after tracking loss or a sequence change).
  void Reset();

  const DynamicFilterOptions& options() const { return options_; }
  bool has_previous_frame() const { return has_prev_; }

 private:
  struct State {
    bool valid = false;
    KalmanProbability posterior;
    // Depth-residual test: 3-D anchor in this frame's camera coordinates (metres).
    bool has_anchor = false;
    cv::Vec3d anchor = cv::Vec3d(0, 0, 0);
    int anchor_age = 0;
  };
  // What the steps of Process share about the frame being classified.
  struct FrameStep {
    explicit FrameStep(const FilterInput& frame) : input(frame) {}
    const FilterInput& input;
    std::vector<cv::Point2f> geom;             // keypoints, undistorted when given (for F)
    std::vector<int> matches;                  // previous-frame feature per feature (-1: none)
    bool depth_mode = false;                   // the depth-residual test replaces F (ours)
    bool test_outside = false;                 // and runs outside the boxes too (full mode)
    double region_prior = 0;                   // prior of a new track in the dynamic region
    std::vector<KalmanProbability> posterior;  // per matched, observed feature
    std::vector<char> has_posterior;
    std::vector<double> depth_distances;  // depth mode: residual per feature (-1: none)
    std::vector<uint8_t> depth_planar;    // 1: depth_distances[i] is an anchor's 2-D residual
    std::vector<State> anchors;           // depth mode: 3-D anchors per feature
    cv::Matx33d cam_from_world_rotation = cv::Matx33d::eye();
    cv::Vec3d cam_from_world_translation = cv::Vec3d(0, 0, 0);
  };
  // The motion between the previous frame and this one that the epipolar test measures against.
  struct MotionModel {
    bool fundamental_ok = false;
    cv::Matx33d fundamental;
    bool use_homography = false;  // degenerate motion: H replaces F
    cv::Matx33d homography = cv::Matx33d::eye();
  };

  // The paper's steps (dynamic_filter.cc). c-e: F from the static matches (GC-RANSAC), then the
  // epipolar probability and the Kalman update of each matched dynamic-region feature.
  void ObserveEpipolar(FrameStep* step, FilterResult* result) const;
  MotionModel FitMotionModel(const std::vector<cv::Point2f>& prev,
                             const std::vector<cv::Point2f>& cur, FilterResult* result) const;
  // f-g: unmatched features inherit from matched neighbours (eqs. 11-12); P > threshold drops.
  std::vector<State> ExpandAndDecide(const FrameStep& step, FilterResult* result) const;
  double Expand(const FrameStep& step, int i, double base, const std::vector<int>& sources) const;
  // Keeps this frame as the previous one of the next.
  void Remember(FrameStep* step, std::vector<State> states);

  // Our extensions (dynamic_filter_depth.cc). The depth-residual observation of matched features
  // in place of F (depth mode).
  void ObserveWithDepth(FrameStep* step, FilterResult* result) const;
  // Depth-residual test (options_.depth_residual): estimates cur_from_prev and fills the
  // observations of matched features; returns false (abstain) when the motion is not reliable.
  // cam_from_world: in: the previous frame's pose in the anchors' frame (world_anchors); out:
  // the current frame's (identity when the motion could not be estimated: anchors restart).
  bool DepthResidual(const FilterInput& input, const std::vector<cv::Point2f>& geom,
                     const std::vector<int>& matches, FilterResult* result,
                     std::vector<double>* distances, std::vector<uint8_t>* planar,
                     std::vector<State>* anchors, cv::Matx33d* cam_from_world_rotation,
                     cv::Vec3d* cam_from_world_translation) const;
  bool SolveFrameMotion(const FilterInput& input, const std::vector<cv::Point2f>& geom,
                        const std::vector<int>& matches, FilterResult* result,
                        cv::Matx33d* rotation, cv::Vec3d* translation) const;
  // consensus_radius: each feature's label becomes the majority of its depth-near neighbours.
  void Consensus(const FilterInput& input, FilterResult* result) const;
  // box_depth_band: marks in-box features at their box's object depth / in the background.
  void SplitBoxesByDepth(const FilterInput& input, FilterResult* result) const;
  std::vector<int> MatchToPrevious(const std::vector<cv::KeyPoint>& keypoints,
                                   const cv::Mat& descriptors) const;

  DynamicFilterOptions options_;
  bool has_prev_ = false;
  std::vector<cv::Point2f> prev_points_;       // keypoint positions (matching)
  std::vector<cv::Point2f> prev_geom_points_;  // undistorted if given (F)
  std::vector<int> prev_octaves_;
  cv::Mat prev_descriptors_;
  std::vector<State> prev_states_;
  std::vector<float> prev_depths_;  // empty without depths
  // world_anchors: the previous frame's pose in the anchors' frame.
  cv::Matx33d prev_cam_from_world_rotation_ = cv::Matx33d::eye();
  cv::Vec3d prev_cam_from_world_translation_ = cv::Vec3d(0, 0, 0);
};

}  // namespace dygslam
