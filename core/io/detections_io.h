// Detection lists: "timestamp x y w h class_id score" per line (pixels, top-left origin), several
// lines per stamp allowed, stamps non-decreasing ('#' comments). Written by `dygslam synth`
// (ground-truth boxes) and usable for detections computed by an external detector.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "core/base/timestamp.h"
#include "core/base/types.h"

namespace dygslam {

// Throws InputError naming the file and line (column count, non-numeric or non-finite values,
// negative sizes, scores outside [0, 1], stamps going backwards, a class_id that is not an
// integer in 0..999999 or, with `num_classes` > 0, not below `num_classes`: the classes of
// `classes_source`, e.g. the detector's names file).
std::map<Timestamp, std::vector<Detection>> ReadDetections(const std::string& path,
                                                           int num_classes = 0,
                                                           const std::string& classes_source = "");

// Detections for a frame stamp: the list with the nearest stamp within max_difference seconds,
// else an empty list (no detection for that frame).
const std::vector<Detection>& DetectionsNear(const std::map<Timestamp, std::vector<Detection>>& all,
                                             Timestamp stamp, double max_difference = 0.02);

}  // namespace dygslam
