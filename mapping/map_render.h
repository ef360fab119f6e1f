// Pictures of an occupancy map for people: a top view (highest occupied cell per x-y column,
// coloured by height) and a horizontal slice. Image rows run from +y (top) to -y, columns from
// -x (left) to +x; one map cell is `pixels_per_cell` pixels.
#pragma once

#include <octomap/OcTree.h>

#include <limits>
#include <opencv2/core.hpp>
#include <string>

namespace dygslam {

struct TopViewOptions {
  // Only cells with centre z in [min_z, max_z] count (e.g. leave out the ceiling).
  double min_z = -std::numeric_limits<double>::infinity();
  double max_z = std::numeric_limits<double>::infinity();
  int pixels_per_cell = 4;
  // Paint columns that were observed free (and not occupied) light grey; unknown stays dark.
  bool draw_free = true;
  // Height scale text in the corner.
  bool draw_legend = true;
  void Check() const;
};

struct SliceOptions {
  int pixels_per_cell = 4;
  void Check() const;
};

// BGR image; unknown columns dark grey, free light grey, occupied coloured (blue low, red high).
// An empty map gives a 1x1 dark image.
cv::Mat RenderTopView(const octomap::OcTree& map, const TopViewOptions& options = {});
// Cells of the slice containing height z: occupied black, free white, unknown grey.
cv::Mat RenderSlice(const octomap::OcTree& map, double z, const SliceOptions& options = {});

// Encodes PNG and writes it atomically. Throws InputError naming the file on failure.
void WritePngAtomically(const std::string& path, const cv::Mat& image);

}  // namespace dygslam
