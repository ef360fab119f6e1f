// Per-feature evaluation of dynamic labels against a ground-truth object-label image (e.g. the
// synthetic generator's SyntheticFrame::object_labels): a feature is truly dynamic if the pixel
// at its position belongs to a mover (label != 0). Counts, per frame and summed over a sequence:
// precision / recall of the filter's dynamic decision, how many truly static features inside the
// dynamic region (detection boxes) were kept, and the recall on movers that no box reported.
//
//   LabelCounts total;
//   total += EvaluateLabels(keypoints, result.DynamicFlags(), in_region, frame.object_labels,
//                           undetected_labels);
//   total.Precision(), total.Recall(), total.StaticInBoxKept(), total.UndetectedRecall()
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace dygslam {

struct LabelCounts {
  int true_positives = 0;         // dynamic, flagged
  int false_positives = 0;        // static, flagged
  int false_negatives = 0;        // dynamic, kept
  int true_negatives = 0;         // static, kept
  int static_in_region = 0;       // static features inside the dynamic region (boxes)
  int static_in_region_kept = 0;  // ... of which kept
  int undetected = 0;             // features on movers listed in `undetected_labels`
  int undetected_flagged = 0;     // ... of which flagged dynamic
  int ignored = 0;                // features near a silhouette (LabelEvaluationOptions)

  // 1 when there is nothing to measure (no flag / no dynamic feature): check the counts too.
  double Precision() const;
  double Recall() const;
  double StaticInBoxKept() const;
  double UndetectedRecall() const;
  int NumDynamic() const { return true_positives + false_negatives; }
  LabelCounts& operator+=(const LabelCounts& other);
  // "precision 0.97 (tp 512 fp 14) recall 0.96 (fn 21) static-in-box kept 0.81 (340/420) ..."
  std::string ToString() const;
};

struct LabelEvaluationOptions {
  // Features with a pixel of the other kind within this radius (px) are ambiguous (their
  // descriptor patch straddles a silhouette) and only counted in `ignored`. 0: the label at the
  // feature's own pixel decides, nothing is ignored.
  int boundary_px = 0;
  void Check() const;
};

// keypoints and flags (nonzero = dynamic) of one frame; in_region (same size, or empty) marks the
// features inside the dynamic region; labels: CV_8UC1 (0 = static, k + 1 = mover k);
// undetected_labels: label values of movers without a detection box. Throws InvalidOptions on
// size or type mismatches (naming what differs).
LabelCounts EvaluateLabels(const std::vector<cv::KeyPoint>& keypoints,
                           const std::vector<uint8_t>& flags, const std::vector<uint8_t>& in_region,
                           const cv::Mat& labels, const std::vector<int>& undetected_labels,
                           const LabelEvaluationOptions& options = LabelEvaluationOptions());

}  // namespace dygslam
