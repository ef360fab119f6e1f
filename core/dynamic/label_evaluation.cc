#include "core/dynamic/label_evaluation.h"

#include <algorithm>
#include <cstdio>

#include "core/base/error.h"

namespace dygslam {
namespace {
double Ratio(int num, int den) { return den == 0 ? 1.0 : static_cast<double>(num) / den; }
}  // namespace

double LabelCounts::Precision() const {
  return Ratio(true_positives, true_positives + false_positives);
}
double LabelCounts::Recall() const {
  return Ratio(true_positives, true_positives + false_negatives);
}
double LabelCounts::StaticInBoxKept() const {
  return Ratio(static_in_region_kept, static_in_region);
}
double LabelCounts::UndetectedRecall() const { return Ratio(undetected_flagged, undetected); }

LabelCounts& LabelCounts::operator+=(const LabelCounts& o) {
  true_positives += o.true_positives;
  false_positives += o.false_positives;
  false_negatives += o.false_negatives;
  true_negatives += o.true_negatives;
  static_in_region += o.static_in_region;
  static_in_region_kept += o.static_in_region_kept;
  undetected += o.undetected;
  undetected_flagged += o.undetected_flagged;
  ignored += o.ignored;
  return *this;
}

std::string LabelCounts::ToString() const {
  char text[320];
  std::snprintf(text, sizeof(text),
                "precision %.3f (tp %d fp %d) recall %.3f (fn %d) static-in-box kept %.3f (%d/%d) "
                "undetected recall %.3f (%d/%d) ignored %d",
                Precision(), true_positives, false_positives, Recall(), false_negatives,
                StaticInBoxKept(), static_in_region_kept, static_in_region, UndetectedRecall(),
                undetected_flagged, undetected, ignored);
  return text;
}

void LabelEvaluationOptions::Check() const {
  DYGSLAM_CHECK_OPTION(boundary_px >= 0 && boundary_px <= 64, "LabelEvaluationOptions.boundary_px");
}

LabelCounts EvaluateLabels(const std::vector<cv::KeyPoint>& keypoints,
                           const std::vector<uint8_t>& flags, const std::vector<uint8_t>& in_region,
                           const cv::Mat& labels, const std::vector<int>& undetected_labels,
                           const LabelEvaluationOptions& options) {
  options.Check();
  if (flags.size() != keypoints.size())
    throw InvalidOptions("EvaluateLabels: " + std::to_string(flags.size()) + " flags for " +
                         std::to_string(keypoints.size()) + " keypoints");
  if (!in_region.empty() && in_region.size() != keypoints.size())
    throw InvalidOptions("EvaluateLabels: " + std::to_string(in_region.size()) +
                         " region flags for " + std::to_string(keypoints.size()) + " keypoints");
  if (labels.empty() || labels.type() != CV_8UC1)
    throw InvalidOptions("EvaluateLabels: labels must be a non-empty CV_8UC1 image");
  LabelCounts c;
  const cv::Rect image(0, 0, labels.cols, labels.rows);
  const int r = options.boundary_px;
  for (size_t i = 0; i < keypoints.size(); ++i) {
    const cv::Point p(cvRound(keypoints[i].pt.x), cvRound(keypoints[i].pt.y));
    if (!image.contains(p)) {
      ++c.ignored;
      continue;
    }
    const int label = labels.at<uint8_t>(p);
    const bool truth = label != 0;
    if (r > 0) {
      const cv::Rect window = cv::Rect(p.x - r, p.y - r, 2 * r + 1, 2 * r + 1) & image;
      const int movers = cv::countNonZero(labels(window));
      if (truth ? movers != window.area() : movers != 0) {
        ++c.ignored;
        continue;
      }
    }
    const bool flagged = flags[i] != 0;
    c.true_positives += truth && flagged;
    c.false_positives += !truth && flagged;
    c.false_negatives += truth && !flagged;
    c.true_negatives += !truth && !flagged;
    if (!truth && !in_region.empty() && in_region[i]) {
      ++c.static_in_region;
      c.static_in_region_kept += !flagged;
    }
    if (truth && std::find(undetected_labels.begin(), undetected_labels.end(), label) !=
                     undetected_labels.end()) {
      ++c.undetected;
      c.undetected_flagged += flagged;
    }
  }
  return c;
}

}  // namespace dygslam
