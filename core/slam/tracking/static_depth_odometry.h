// The second pose estimator of the tracker: when feature tracking is left with too few
// static inliers (a person fills the view), the frame is aligned densely against the last frame
// with a pose, using only the STATIC pixels of both (outside the dynamic mask: detection boxes
// refined by depth, disks around dynamic features) and seeded with the motion model.
//
// Alignment: OpenCV contrib's RGB-D odometry restricted to the static masks (default
// cv::rgbd::ICPOdometry: point-to-plane ICP on depth pyramids; RgbdICPOdometry / RgbdOdometry add
// or use a photometric term instead).
// Verification, independent of the optimiser: the current frame's static pixels (every
// `verify_step_px`) are moved into the reference frame with the estimate and compared with the
// reference depth there. The estimate is accepted only when enough of them land on reference
// static depth (overlap), when most of those agree within the depth tolerance (inlier fraction),
// and when the estimate does not jump away from the seed by more than a camera can move in one
// frame. An unverified estimate is never reported as a pose.
//
//   StaticDepthOdometry odometry(camera, StaticDepthOdometryOptions());
//   StaticDepthEstimate e = odometry.Estimate(reference_view, current_view, cur_from_ref_seed);
//   if (e.verified) cam_from_world = e.cur_from_ref * ref_from_world;
#pragma once

#include <functional>
#include <memory>
#include <opencv2/core.hpp>
#include <vector>

#include "core/base/camera.h"
#include "core/base/error.h"
#include "core/base/rigid3.h"

namespace cv::rgbd {
class Odometry;
struct OdometryFrame;
}  // namespace cv::rgbd

namespace dygslam {

// What the dense estimator needs of a frame. Built by the System for every frame (the images are
// shared, not copied). Used on the tracking thread only.
struct DenseView {
  cv::Mat gray;         // CV_8UC1
  cv::Mat depth;        // CV_32FC1 metres, 0 = no measurement
  cv::Mat static_mask;  // CV_8UC1, nonzero = static pixel usable for alignment; empty = all
  // When set, the static mask is made by this on its first use instead (StaticMask()): most
  // frames are never aligned, and the mask (boxes refined by depth, disks around dynamic
  // features, dilation) costs about a millisecond per frame.
  std::function<cv::Mat()> make_static_mask;
  // static_mask, or the one make_static_mask makes (once).
  const cv::Mat& StaticMask() const {
    if (make_static_mask && !static_mask_made_) {
      made_static_mask_ = make_static_mask();
      static_mask_made_ = true;
    }
    return make_static_mask ? made_static_mask_ : static_mask;
  }
  // The aligner's pyramids of this view, made on its first alignment and reused when the view is
  // aligned again (a frame aligned as the current one is the next frame's reference): the images
  // above must not change once the view has been used.
  mutable std::shared_ptr<cv::rgbd::OdometryFrame> odometry_frame;

 private:
  mutable cv::Mat made_static_mask_;
  mutable bool static_mask_made_ = false;
};

// How the static pixels are aligned (cv::rgbd odometries).
enum class DenseAlignment {
  kRgbdIcp,     // point-to-plane ICP + photometric (RgbdICPOdometry)
  kIcp,         // point-to-plane ICP on the depth only (ICPOdometry)
  kPhotometric  // photometric on intensity with depth (RgbdOdometry)
};

struct StaticDepthOdometryOptions {
  // Chosen by measurement on bonn_crowd_part (BENCHMARKS.md): depth-only ICP gave the
  // lowest ATE; the photometric terms suffer from the people's motion blur and exposure changes.
  DenseAlignment alignment = DenseAlignment::kIcp;
  double min_depth = 0.3;                            // metres
  double max_depth = 6.0;                            // metres
  double max_depth_diff = 0.07;                      // metres, ICP correspondence rejection
  double max_points_part = 0.07;                     // share of pixels used per pyramid level
  std::vector<int> iteration_counts = {10, 10, 10};  // OpenCV order (finest level first)
  // The alignment runs on the images reduced by this factor (1: full size; depth and mask by
  // nearest neighbour, so no depth is mixed across an edge); the verification below always uses
  // the full images. Halving them makes a fallback frame several times cheaper (the normals and
  // pyramids of a 640x480 frame are most of its cost) for the same verified accuracy.
  int align_downsample = 2;
  // Verification.
  int verify_step_px = 4;                 // every n-th pixel in x and y
  double inlier_depth_tol = 0.03;         // metres at 1 m ...
  double inlier_depth_tol_per_m2 = 0.01;  // ... plus this times depth^2 (depth noise grows as z^2)
  double min_inlier_fraction = 0.6;       // of the correspondences
  int min_inliers = 800;                  // sampled pixels that agree
  double max_translation_from_seed = 0.10;  // metres: more than a hand-held camera moves in 33 ms
  double max_rotation_from_seed_deg = 8.0;
  // The constrained estimate (EstimateWithPrior): where the static pixels are too few or too
  // narrow a strip for the alignment above (it slides along the directions they leave free), a
  // point-to-plane alignment with the motion model as a prior, each weighted by its uncertainty.
  double prior_sigma_translation = 0.003;  // metres per frame the motion model may be off
  double prior_sigma_rotation_deg = 1.0;   // degrees per frame
  double point_sigma = 0.01;               // metres, point-to-plane residual of a sampled pixel
  double intensity_sigma = 10.0;           // grey levels, intensity residual of a sampled pixel
                                           // (0: depth only)
  int constrained_step_px = 2;             // every n-th pixel in x and y
  int constrained_iterations = 15;
  int constrained_min_inliers = 150;  // verification of the constrained estimate (sampled as
                                      // the verification above, every verify_step_px)
  void Check() const;
};

// Agreement of two depth views under a relative pose (cur_from_ref).
struct DepthAgreement {
  int samples = 0;          // current static pixels with depth, sampled
  int correspondences = 0;  // of those, landing on reference static depth
  int inliers = 0;          // of those, agreeing within the tolerance
  double rmse = 0;          // metres, over the inliers
  double inlier_fraction() const {
    return correspondences > 0 ? double(inliers) / correspondences : 0;
  }
};

struct StaticDepthEstimate {
  bool converged = false;  // OpenCV's odometry returned a pose
  bool verified = false;   // ... and it passed the verification
  Rigid3d cur_from_ref;
  DepthAgreement agreement;
  double time_ms = 0;
};

class StaticDepthOdometry {
 public:
  // camera: pinhole intrinsics of the (undistorted) images. Throws InvalidOptions.
  StaticDepthOdometry(const PinholeCamera& camera, const StaticDepthOdometryOptions& options);
  ~StaticDepthOdometry();
  StaticDepthOdometry(const StaticDepthOdometry&) = delete;
  StaticDepthOdometry& operator=(const StaticDepthOdometry&) = delete;

  // Aligns `current` onto `reference`. Throws InputError when the views do not match the camera.
  StaticDepthEstimate Estimate(const DenseView& reference, const DenseView& current,
                               const Rigid3d& cur_from_ref_seed) const;
  // Aligns `current` onto `reference` by Gauss-Newton on point-to-plane residuals of the static
  // pixels plus a prior pulling the pose towards the seed (one frame of motion-model error:
  // prior_sigma_*): the pixels decide the directions they constrain, the motion model the rest.
  // Verified as Estimate, with constrained_min_inliers instead of min_inliers.
  StaticDepthEstimate EstimateWithPrior(const DenseView& reference, const DenseView& current,
                                        const Rigid3d& cur_from_ref_seed) const;
  // The verification measure alone (also used by tests).
  DepthAgreement Agreement(const DenseView& reference, const DenseView& current,
                           const Rigid3d& cur_from_ref) const;

  const StaticDepthOdometryOptions& options() const { return options_; }

 private:
  void CheckView(const DenseView& view, const char* which) const;
  cv::Size AlignSize() const;  // of the images the alignment runs on

  PinholeCamera camera_;
  StaticDepthOdometryOptions options_;
  cv::Ptr<cv::rgbd::Odometry> odometry_;
};

}  // namespace dygslam
