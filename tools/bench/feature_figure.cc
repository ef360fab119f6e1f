#include "tools/bench/feature_figure.h"

#include <algorithm>
#include <cstdio>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "core/base/error.h"
#include "core/dynamic/dynamic_filter.h"
#include "core/dynamic/yolo_detector.h"
#include "core/slam/feature/orb_extractor.h"

namespace dygslam {
namespace {

const cv::Scalar kGreen(60, 200, 60);
const cv::Scalar kRed(40, 40, 230);
const cv::Scalar kYellow(0, 220, 255);

void DrawLabel(cv::Mat& panel, const std::string& title, const std::string& counts) {
  cv::rectangle(panel, cv::Rect(0, 0, panel.cols, 44), cv::Scalar(0, 0, 0), cv::FILLED);
  cv::putText(panel, title, cv::Point(6, 18), cv::FONT_HERSHEY_SIMPLEX, 0.5,
              cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  cv::putText(panel, counts, cv::Point(6, 38), cv::FONT_HERSHEY_SIMPLEX, 0.45,
              cv::Scalar(220, 220, 220), 1, cv::LINE_AA);
}

cv::Mat Panel(const cv::Mat& bgr, double scale) {
  cv::Mat panel;
  cv::resize(bgr, panel, cv::Size(), scale, scale, cv::INTER_AREA);
  // Dim the photo a little so the markers stand out.
  panel.convertTo(panel, -1, 0.8, 0);
  return panel;
}

void DrawBoxes(cv::Mat& panel, const std::vector<Detection>& boxes, double scale) {
  for (const Detection& d : boxes) {
    const cv::Rect r(cv::Point(cvRound(d.box.x * scale), cvRound(d.box.y * scale)),
                     cv::Point(cvRound((d.box.x + d.box.width) * scale),
                               cvRound((d.box.y + d.box.height) * scale)));
    cv::rectangle(panel, r, kRed, 2, cv::LINE_AA);
  }
}

void DrawPoint(cv::Mat& panel, const cv::Point2f& p, double scale, const cv::Scalar& color,
               bool cross) {
  const cv::Point c(cvRound(p.x * scale), cvRound(p.y * scale));
  if (cross) {
    cv::drawMarker(panel, c, color, cv::MARKER_TILTED_CROSS, 7, 1, cv::LINE_AA);
  } else {
    cv::circle(panel, c, 3, color, 1, cv::LINE_AA);
  }
}

}  // namespace

void FeatureFigureOptions::Check() const {
  DYGSLAM_CHECK_OPTION(warmup_frames >= 0 && warmup_frames <= 1000, "warmup_frames");
  DYGSLAM_CHECK_OPTION(panel_scale > 0.1 && panel_scale <= 2.0, "panel_scale");
}

FeatureFigure DrawFeatureFigure(const RgbdDataset& dataset, size_t rgb_entry,
                                const SystemOptions& options,
                                const FeatureFigureOptions& figure_options) {
  figure_options.Check();
  if (rgb_entry >= dataset.num_rgb_entries())
    throw InputError(dataset.directory(), 0,
                     "features picture: rgb.txt entry " + std::to_string(rgb_entry) +
                         " out of range (" + std::to_string(dataset.num_rgb_entries()) +
                         " entries)");
  if (!dataset.FrameForRgbEntry(rgb_entry))
    throw InputError(
        dataset.directory(), 0,
        "features picture: rgb.txt entry " + std::to_string(rgb_entry) + " has no depth partner");
  DetectorOptions detector_options = options.detector;
  if (detector_options.cfg_path.empty())
    detector_options = DetectorOptionsForModel("yolo-fastest-1.1");
  std::unique_ptr<YoloDetector> detector = YoloDetector::Create(detector_options);
  OrbExtractor extractor(options.orb);
  DynamicFilterOptions boxes_options = options.filter;
  boxes_options.mode = FilterMode::kBoxes;
  DynamicFilterOptions full_options = options.filter;
  full_options.mode = FilterMode::kFull;
  DynamicFilter boxes_filter(boxes_options), full_filter(full_options);

  const size_t first = rgb_entry >= static_cast<size_t>(figure_options.warmup_frames)
                           ? rgb_entry - figure_options.warmup_frames
                           : 0;
  FeatureFigure figure;
  for (size_t k = first; k <= rgb_entry; ++k) {
    const auto index = dataset.FrameForRgbEntry(k);
    if (!index) continue;
    const cv::Mat bgr = dataset.LoadRgb(*index, options.camera.width, options.camera.height);
    cv::Mat gray;
    cv::cvtColor(bgr, gray, cv::COLOR_BGR2GRAY);
    const OrbFeatures features = extractor.Extract(gray);
    const std::vector<Detection> boxes = detector->Detect(bgr);
    const cv::Mat descriptors = features.DescriptorMatrix();
    std::vector<cv::Point2f> undistorted;
    FilterInput input(features.keypoints, descriptors, boxes);
    if (options.camera.HasDistortion() && !features.keypoints.empty()) {
      std::vector<cv::Point2f> points;
      for (const cv::KeyPoint& kp : features.keypoints) points.push_back(kp.pt);
      cv::undistortPoints(points, undistorted, options.camera.K(), options.camera.DistCoeffs(),
                          cv::noArray(), options.camera.K());
      input.undistorted_points = &undistorted;
    }
    const FilterResult by_boxes = boxes_filter.Process(input);
    const FilterResult full = full_filter.Process(input);
    if (k != rgb_entry) continue;

    const double s = figure_options.panel_scale;
    cv::Mat all = Panel(bgr, s), boxed = Panel(bgr, s), dyg = Panel(bgr, s);
    int kept_in_boxes = 0;
    for (size_t i = 0; i < features.keypoints.size(); ++i) {
      const cv::Point2f& p = features.keypoints[i].pt;
      DrawPoint(all, p, s, kGreen, false);
      DrawPoint(boxed, p, s, by_boxes.features[i].is_dynamic ? kRed : kGreen,
                by_boxes.features[i].is_dynamic);
      const FeatureStatus& f = full.features[i];
      if (f.is_dynamic) {
        DrawPoint(dyg, p, s, kRed, true);
      } else if (f.in_dynamic_region) {
        DrawPoint(dyg, p, s, kYellow, false);
        ++kept_in_boxes;
      } else {
        DrawPoint(dyg, p, s, kGreen, false);
      }
    }
    DrawBoxes(boxed, boxes, s);
    DrawBoxes(dyg, boxes, s);
    const int n = static_cast<int>(features.keypoints.size());
    figure.num_features = n;
    figure.num_boxes = static_cast<int>(boxes.size());
    figure.num_removed_boxes = by_boxes.num_dynamic;
    figure.num_dynamic_full = full.num_dynamic;
    figure.num_kept_in_boxes_full = kept_in_boxes;
    char text[160];
    std::snprintf(text, sizeof(text), "%d features, all used", n);
    DrawLabel(all, "no filter (our tracker)", text);
    std::snprintf(text, sizeof(text), "%d boxes: %d removed, %d static", figure.num_boxes,
                  by_boxes.num_dynamic, n - by_boxes.num_dynamic);
    DrawLabel(boxed, "box removal only", text);
    std::snprintf(text, sizeof(text), "%d dynamic, %d static (%d of them in boxes)",
                  full.num_dynamic, n - full.num_dynamic, kept_in_boxes);
    DrawLabel(dyg, "full method (DYG-SLAM)", text);
    cv::hconcat(std::vector<cv::Mat>{all, boxed, dyg}, figure.image);
    char caption[512];
    std::snprintf(
        caption, sizeof(caption),
        "Features on rgb.txt entry %zu (stamp %s), after %zu preceding frames through the "
        "filters: green = static (used for tracking), red crosses = removed as dynamic, "
        "yellow = inside a person box but kept as static by the geometry probability, "
        "red rectangles = detector boxes (%d). %d features; box removal drops %d, the "
        "full method %d. (On crowded frames the running system also extracts "
        "replacement features outside the boxes; those are not drawn.)",
        rgb_entry, dataset.frame(*dataset.FrameForRgbEntry(rgb_entry)).rgb_stamp.ToString().c_str(),
        rgb_entry - first, figure.num_boxes, n, by_boxes.num_dynamic, full.num_dynamic);
    figure.caption = caption;
  }
  return figure;
}

}  // namespace dygslam
