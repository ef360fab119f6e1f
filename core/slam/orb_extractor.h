// ORB features ORB-SLAM2-style: scale pyramid, FAST with an initial and a fallback threshold per
// grid cell, quadtree distribution per level, intensity-centroid orientation, steered BRIEF.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "core/base/error.h"

namespace dygslam {

struct OrbExtractorOptions {
  int num_features = 1000;     // ORBextractor.nFeatures
  double scale_factor = 1.2;   // ORBextractor.scaleFactor
  int num_levels = 8;          // ORBextractor.nLevels
  int ini_th_fast = 20;        // ORBextractor.iniThFAST
  int min_th_fast = 7;         // ORBextractor.minThFAST
  void Check() const {
    DYGSLAM_CHECK_OPTION(num_features > 0 && num_features <= 100000, "ORBextractor.nFeatures");
    DYGSLAM_CHECK_OPTION(scale_factor > 1.0 && scale_factor < 4.0, "ORBextractor.scaleFactor");
    DYGSLAM_CHECK_OPTION(num_levels >= 1 && num_levels <= 32, "ORBextractor.nLevels");
    DYGSLAM_CHECK_OPTION(ini_th_fast > 0 && ini_th_fast < 255, "ORBextractor.iniThFAST");
    DYGSLAM_CHECK_OPTION(min_th_fast > 0 && min_th_fast <= ini_th_fast, "ORBextractor.minThFAST");
  }
};

}  // namespace dygslam
