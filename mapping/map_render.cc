#include "mapping/map_render.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "core/base/error.h"
#include "core/io/file_util.h"
#include "mapping/map_compare.h"

namespace dygslam {
namespace {

const cv::Vec3b kUnknown(40, 40, 40);
const cv::Vec3b kFreeTop(190, 190, 190);

struct Grid {
  double min_x = 0, min_y = 0, res = 0;
  int cols = 0, rows = 0;
  bool Index(const octomap::point3d& p, int* col, int* row) const {
    *col = static_cast<int>(std::floor((p.x() - min_x) / res));
    *row = rows - 1 - static_cast<int>(std::floor((p.y() - min_y) / res));
    return *col >= 0 && *col < cols && *row >= 0 && *row < rows;
  }
};

bool MakeGrid(const octomap::OcTree& map, Grid* grid) {
  if (map.size() == 0) return false;
  double min_x, min_y, min_z, max_x, max_y, max_z;
  map.getMetricMin(min_x, min_y, min_z);
  map.getMetricMax(max_x, max_y, max_z);
  grid->res = map.getResolution();
  grid->min_x = min_x;
  grid->min_y = min_y;
  grid->cols = std::max(1, static_cast<int>(std::ceil((max_x - min_x) / grid->res - 1e-6)));
  grid->rows = std::max(1, static_cast<int>(std::ceil((max_y - min_y) / grid->res - 1e-6)));
  return grid->cols <= 20000 && grid->rows <= 20000;
}

cv::Mat Enlarge(const cv::Mat& image, int pixels_per_cell) {
  if (pixels_per_cell == 1) return image;
  cv::Mat out;
  cv::resize(image, out, cv::Size(), pixels_per_cell, pixels_per_cell, cv::INTER_NEAREST);
  return out;
}

}  // namespace

void TopViewOptions::Check() const {
  DYGSLAM_CHECK_OPTION(!(min_z > max_z), "TopView.min_z");
  DYGSLAM_CHECK_OPTION(pixels_per_cell >= 1 && pixels_per_cell <= 32, "TopView.pixels_per_cell");
}

void SliceOptions::Check() const {
  DYGSLAM_CHECK_OPTION(pixels_per_cell >= 1 && pixels_per_cell <= 32, "Slice.pixels_per_cell");
}

cv::Mat RenderTopView(const octomap::OcTree& map, const TopViewOptions& options) {
  options.Check();
  Grid grid;
  if (!MakeGrid(map, &grid)) return cv::Mat(1, 1, CV_8UC3, cv::Scalar(kUnknown));
  const float lowest = -std::numeric_limits<float>::infinity();
  cv::Mat height(grid.rows, grid.cols, CV_32FC1, cv::Scalar(lowest));
  cv::Mat free_seen = cv::Mat::zeros(grid.rows, grid.cols, CV_8UC1);
  double z_lo = std::numeric_limits<double>::infinity(), z_hi = -z_lo;
  ForEachCell(map, [&](const octomap::point3d& c, bool occupied) {
    if (c.z() < options.min_z || c.z() > options.max_z) return;
    int col, row;
    if (!grid.Index(c, &col, &row)) return;
    if (occupied) {
      float& h = height.at<float>(row, col);
      h = std::max(h, c.z());
      z_lo = std::min(z_lo, static_cast<double>(c.z()));
      z_hi = std::max(z_hi, static_cast<double>(c.z()));
    } else {
      free_seen.at<uint8_t>(row, col) = 1;
    }
  });

  cv::Mat image(grid.rows, grid.cols, CV_8UC3, cv::Scalar(kUnknown));
  if (std::isfinite(z_lo)) {
    const double span = std::max(z_hi - z_lo, 1e-6);
    cv::Mat level(grid.rows, grid.cols, CV_8UC1, cv::Scalar(0));
    for (int r = 0; r < grid.rows; ++r) {
      for (int c = 0; c < grid.cols; ++c) {
        const float h = height.at<float>(r, c);
        if (std::isfinite(h))
          level.at<uint8_t>(r, c) = cv::saturate_cast<uint8_t>((h - z_lo) / span * 255.0);
      }
    }
    cv::Mat coloured;
    cv::applyColorMap(level, coloured, cv::COLORMAP_TURBO);
    for (int r = 0; r < grid.rows; ++r) {
      for (int c = 0; c < grid.cols; ++c) {
        if (std::isfinite(height.at<float>(r, c))) {
          image.at<cv::Vec3b>(r, c) = coloured.at<cv::Vec3b>(r, c);
        } else if (options.draw_free && free_seen.at<uint8_t>(r, c)) {
          image.at<cv::Vec3b>(r, c) = kFreeTop;
        }
      }
    }
  }
  cv::Mat out = Enlarge(image, options.pixels_per_cell);
  if (options.draw_legend && std::isfinite(z_lo) && out.cols >= 120 && out.rows >= 30) {
    char text[96];
    std::snprintf(text, sizeof(text), "z %.2f..%.2f m, %.0f cm/cell", z_lo, z_hi, grid.res * 100.0);
    cv::putText(out, text, cv::Point(4, 14), cv::FONT_HERSHEY_PLAIN, 0.9, cv::Scalar(255, 255, 255),
                1, cv::LINE_AA);
  }
  return out;
}

cv::Mat RenderSlice(const octomap::OcTree& map, double z, const SliceOptions& options) {
  options.Check();
  Grid grid;
  if (!MakeGrid(map, &grid)) return cv::Mat(1, 1, CV_8UC3, cv::Scalar(128, 128, 128));
  octomap::OcTreeKey slice_key;
  cv::Mat image(grid.rows, grid.cols, CV_8UC3, cv::Scalar(128, 128, 128));
  if (!map.coordToKeyChecked(octomap::point3d(0, 0, static_cast<float>(z)), slice_key)) {
    return Enlarge(image, options.pixels_per_cell);
  }
  const double slice_centre = map.keyToCoord(slice_key[2]);
  const double half = 0.5 * map.getResolution();
  ForEachCell(map, [&](const octomap::point3d& c, bool occupied) {
    if (std::abs(c.z() - slice_centre) > half * 0.5) return;
    int col, row;
    if (!grid.Index(c, &col, &row)) return;
    image.at<cv::Vec3b>(row, col) = occupied ? cv::Vec3b(0, 0, 0) : cv::Vec3b(255, 255, 255);
  });
  return Enlarge(image, options.pixels_per_cell);
}

void WritePngAtomically(const std::string& path, const cv::Mat& image) {
  std::vector<uint8_t> bytes;
  if (image.empty() || !cv::imencode(".png", image, bytes)) {
    throw InputError(path, 0, "cannot encode PNG");
  }
  WriteFileAtomically(path, std::string(bytes.begin(), bytes.end()));
}

}  // namespace dygslam
