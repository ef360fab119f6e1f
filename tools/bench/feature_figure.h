// The features picture of `dygslam bench` (like the paper's Fig. 3 and 10): one frame drawn three
// ways side by side: every ORB feature (no filter, our tracker), box removal only, and
// the full method (static features green, dynamic red, static features kept inside a box yellow,
// detector boxes red). The filters run on the frames before the drawn one as well, so the
// Kalman-fused probabilities of the full method are those of a running system.
#pragma once

#include <opencv2/core.hpp>
#include <string>

#include "core/io/dataset.h"
#include "core/system/system.h"

namespace dygslam {

struct FeatureFigureOptions {
  int warmup_frames = 10;     // frames run through the filters before the drawn one
  double panel_scale = 0.75;  // each panel is the image scaled by this
  void Check() const;
};

struct FeatureFigure {
  cv::Mat image;        // CV_8UC3, three panels side by side
  std::string caption;  // one Markdown sentence: frame, counts per panel
  int num_features = 0;
  int num_boxes = 0;
  int num_removed_boxes = 0;  // box removal: features inside boxes
  int num_dynamic_full = 0;   // full method: features judged dynamic
  int num_kept_in_boxes_full = 0;
};

// Draws rgb.txt entry `rgb_entry` of `dataset` with the ORB, detector and filter options of
// `options` (options.detector with an empty cfg_path: the system's default model). Throws
// InputError when the entry has no depth partner / is out of range, or the model is missing.
FeatureFigure DrawFeatureFigure(const RgbdDataset& dataset, size_t rgb_entry,
                                const SystemOptions& options,
                                const FeatureFigureOptions& figure_options = {});

}  // namespace dygslam
