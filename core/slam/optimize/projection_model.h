// The pinhole projection with the RGB-D virtual right camera (bf = baseline x fx), as the cost
// functions and bundle problems use it.
#pragma once

namespace dygslam {

struct ProjectionModel {
  double fx = 0, fy = 0, cx = 0, cy = 0, bf = 0;
};

}  // namespace dygslam
