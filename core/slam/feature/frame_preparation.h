// Frame preparation beside the ORB extractor: what an RGB-D frame's image becomes before the
// dynamic filter and the tracker see it (the first half of System::FeedRgbdFrame, like
// stella_vslam's create_RGBD_frame): its grey image, its ORB features, and on crowded frames a
// second extraction outside the person boxes that tops the features up to the budget.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "core/slam/feature/orb_extractor.h"

namespace dygslam {

// CV_8UC1 grey of a CV_8UC3 BGR image; a CV_8UC1 image is returned as is (shared).
cv::Mat GrayImage(const cv::Mat& rgb);

// Crowded frames: adds to `kept` up to (budget - kept->keypoints.size()) features extracted from
// `gray` outside `excluded` (person boxes, image coordinates) and outside `mask` (nonzero = no
// features), skipping corners already kept (same level, within 2 px). `cache` holds the pyramid
// and FAST corners of the first extraction of `gray` (OrbExtractionCache), so this costs only
// the selection and the descriptors. Nothing happens when `kept` already holds the budget.
void TopUpFeatures(const OrbExtractor& extractor, const cv::Mat& gray, const cv::Mat& mask,
                   const std::vector<cv::Rect>& excluded, int budget, OrbExtractionCache* cache,
                   OrbFeatures* kept);

}  // namespace dygslam
