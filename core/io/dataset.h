// TUM RGB-D / Bonn RGB-D Dynamic dataset folders:
//   rgb.txt, depth.txt ("timestamp path" lines, '#' comments), groundtruth.txt
//   ("timestamp tx ty tz qx qy qz qw"), optional associations.txt
//   ("t_rgb rgb_path t_depth depth_path"). rgb/depth are associated one-to-one by nearest
//   timestamp within max_time_difference (default 0.02 s).
#pragma once

#include <filesystem>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/base/timestamp.h"
#include "core/base/types.h"
#include "core/io/file_util.h"

namespace dygslam {

struct DatasetOptions {
  double max_time_difference = 0.02;  // seconds, rgb <-> depth association
  bool use_associations_file = true;  // use associations.txt when present
  // Image paths that point outside the dataset folder ("../../etc/passwd", an absolute path
  // elsewhere): a warning on stderr naming the list file and line (false), or an InputError (true).
  bool refuse_outside_paths = false;
  void Check() const;
};

struct RgbdFrameEntry {
  Timestamp rgb_stamp;
  std::string rgb_path;  // absolute
  Timestamp depth_stamp;
  std::string depth_path;  // absolute
  // Where the entries are listed ("/data/x/rgb.txt:12"), for messages about the images.
  std::string rgb_listed_at;
  std::string depth_listed_at;
};

// The two sides of "FIRST:LAST" as written, each a non-negative integer or empty (nullopt).
// Throws InvalidOptions naming --frames for anything else.
struct FrameRangeText {
  std::optional<size_t> first, last;
};
FrameRangeText SplitFrameRange(const std::string& text);

// "FIRST:LAST" (either side may be empty) -> [first, last) of rgb.txt entries, LAST clamped to
// `total`. Throws InvalidOptions naming --frames for anything else or an empty range.
// `note`, when given, is set to a warning when LAST is beyond `total` (the range is then cut to
// the entries there are), cleared otherwise.
std::pair<size_t, size_t> ParseFrameRange(const std::string& text, size_t total,
                                          std::string* note = nullptr);

class RgbdDataset {
 public:
  // Throws InputError naming the file and line for missing files, malformed lines, unsorted,
  // duplicate or negative timestamps, and image paths that are not regular files (a FIFO, a
  // device, a directory). A UTF-8 byte order mark at the start of a list is skipped; paths echoed
  // in messages are cut to 200 characters.
  static RgbdDataset Open(const std::string& directory, const DatasetOptions& options = {});

  const std::string& directory() const { return directory_; }
  size_t size() const { return frames_.size(); }
  const RgbdFrameEntry& frame(size_t i) const { return frames_.at(i); }
  const std::vector<RgbdFrameEntry>& frames() const { return frames_; }
  // Number of rgb.txt entries; frames() is the subset that has a depth partner.
  size_t num_rgb_entries() const { return num_rgb_entries_; }
  // Index into frames() of rgb.txt entry k, or nullopt if that entry has no depth partner.
  std::optional<size_t> FrameForRgbEntry(size_t k) const;
  // The stamp of rgb.txt entry k as a bound of a range: the first frame with a depth partner at
  // or after it; past the last frame when there is none.
  Timestamp StampOfRgbEntry(size_t k) const;

  // CV_8UC3 BGR. Throws InputError naming the file and its list line if missing, unreadable or of
  // the wrong size; a PNG's size is checked from its header before it is decoded (a 20000x20000
  // PNG is refused without allocating 1.2 GB).
  cv::Mat LoadRgb(size_t i, int expected_width = 0, int expected_height = 0) const;
  // CV_16UC1 raw depth (divide by DepthMapFactor for metres). Same errors.
  cv::Mat LoadDepth(size_t i, int expected_width = 0, int expected_height = 0) const;

  bool has_groundtruth() const { return !groundtruth_path_.empty(); }
  const std::string& groundtruth_path() const { return groundtruth_path_; }
  // Why a groundtruth.txt that is there is not used: "DIR/groundtruth.txt: not a regular file: a
  // FIFO" (a directory, a device, a link to /dev/zero); empty when it is a regular file or absent.
  const std::string& groundtruth_problem() const { return groundtruth_problem_; }
  // Images in rgb/ or depth/ that rgb.txt / depth.txt do not list ("DIR/rgb.txt lists 200 of the
  // 360 images in rgb/ ..."): a list cut short at a line boundary. Empty when every image is
  // listed.
  const std::string& listing_problem() const { return listing_problem_; }

 private:
  std::string directory_;
  std::vector<RgbdFrameEntry> frames_;
  std::vector<std::optional<size_t>> rgb_entry_to_frame_;
  size_t num_rgb_entries_ = 0;
  std::string groundtruth_path_;
  std::string groundtruth_problem_;
  std::string listing_problem_;
};

// "" when every frame of rgb entries [first, last) has a ground-truth pose within `tolerance_s`
// (the ATE's association); else how many have none, before the ground truth's start, after its
// end or in its gaps ("DIR/groundtruth.txt covers 12.1 s (...); 40 of the 360 frames have no
// pose of it within 0.02 s (0 before it, 40 after it, 0 in its gaps) ..."): a ground truth cut
// short or with holes reads as a scored run with fewer pairs, and nothing else tells.
std::string GroundTruthCoverageNote(const RgbdDataset& dataset, size_t first, size_t last,
                                    const std::vector<StampedPose>& groundtruth,
                                    double tolerance_s = 0.02);

// A hand-held or robot camera moves at a few m/s; a ground truth faster than this between two
// consecutive poses is in another unit (millimetres) or has a corrupt line.
inline constexpr double kMaxGroundTruthSpeed = 50.0;  // m/s
// "" when no two consecutive poses of `groundtruth` are farther apart than kMaxGroundTruthSpeed
// allows; else the first such pair, named by `path` and stamp.
std::string ImplausibleGroundTruthNote(const std::string& path,
                                       const std::vector<StampedPose>& groundtruth);

// The range an RGB-D sensor measures (metres): structured light and time of flight reach 4 to
// 10 m (Kinect v1 / v2, RealSense D4xx), none beyond 12 m; a saturated 16-bit pixel at the TUM
// scale (65535 / 5000 = 13.1 m) is beyond it. Below 5 cm no sensor gives depth.
inline constexpr double kMaxSensorDepthMetres = 12.0;
inline constexpr double kMinSensorDepthMetres = 0.05;
// A scene whose median depth is this close fills the view with surfaces within arm's reach: no
// room, corridor or street a SLAM camera maps. A DepthMapFactor 10 or 20 times too large puts an
// indoor scene (median 2-3 m) there while most pixels still lie beyond kMinSensorDepthMetres.
inline constexpr double kMinPlausibleMedianDepthMetres = 0.5;

// The depth of a few frames of a run in metres (raw / DepthMapFactor), against the sensor range.
struct DepthRangeSample {
  size_t images = 0;
  size_t valid = 0;   // pixels with depth (raw > 0)
  size_t beyond = 0;  // ... farther than kMaxSensorDepthMetres
  size_t below = 0;   // ... closer than kMinSensorDepthMetres
  double median_m = 0;
  std::string example;  // the first sampled depth image
};
// Up to `max_images` frames spread evenly over rgb entries [first, last) (those with a depth
// partner). Throws what LoadDepth throws.
DepthRangeSample SampleDepthRange(const RgbdDataset& dataset, size_t first, size_t last,
                                  double depth_map_factor, int width, int height,
                                  size_t max_images = 5);
// "" when most valid pixels lie within the sensor range and the median is not closer than
// kMinPlausibleMedianDepthMetres; else what is wrong and the likely cause (DepthMapFactor off by
// an order of magnitude or more, saturated or invalid depth images).
std::string ImplausibleDepth(const DepthRangeSample& sample, double depth_map_factor);

// Whether `dir` is a dataset folder (TUM / Bonn layout): it holds rgb.txt and depth.txt, or an
// associations.txt that pairs the images.
bool IsDatasetFolder(const std::filesystem::path& dir);
// The first output that is one of the dataset's images, "" when there is none: every image its
// lists name (also by an absolute path outside the dataset folder) and every file in its rgb/
// and depth/ folders.
std::string FindOutputOnDatasetImage(const RgbdDataset& dataset, const std::string& dataset_dir,
                                     const std::vector<NamedPath>& outputs);
// Whether `path` names an image file a dataset holds: .png, .jpg or .jpeg, in any case.
bool HasImageExtension(const std::filesystem::path& path);
// The dataset folder (IsDatasetFolder) that an existing file `path` belongs
// to: the folder itself or its parent (rgb/, depth/); "" when it belongs to none or does not exist.
// An output onto such a file would destroy a user's data.
std::string DatasetFolderOf(const std::string& path);

// The image folder of a dataset (a folder whose parent is a dataset folder and that is named rgb,
// depth or mask or holds a .png / .jpg image) that `dir` is or lies inside, "" when none: outputs
// written there would be listed with the sequence's images by later reads of the folder.
std::string DatasetImageFolderOf(const std::filesystem::path& dir);

}  // namespace dygslam
