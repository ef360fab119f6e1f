#include "core/io/dataset.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <set>

#include "core/base/echo.h"
#include "core/base/error.h"
#include "core/base/input_file.h"
#include "core/base/number_option.h"
#include "core/io/association.h"
#include "core/io/file_util.h"
#include "core/io/png_reader.h"

namespace dygslam {
namespace fs = std::filesystem;

void DatasetOptions::Check() const {
  DYGSLAM_CHECK_OPTION(
      std::isfinite(max_time_difference) && max_time_difference > 0 && max_time_difference <= 1.0,
      "max_time_difference");
}

namespace {

struct ListEntry {
  Timestamp stamp;
  std::string path;  // absolute
  int line = 0;
};

Timestamp ParseStamp(const std::string& file, int line, const std::string& text) {
  const std::optional<Timestamp> t = Timestamp::Parse(text);
  if (!t) throw InputError(file, line, "malformed timestamp '" + Abbreviate(text) + "'");
  if (t->nanoseconds() < 0) throw InputError(file, line, "negative timestamp " + Abbreviate(text));
  return *t;
}

// Image paths of one list file that point outside the dataset folder: warned once per list file
// (the first such line and how many there are), not once per line.
class OutsidePaths {
 public:
  explicit OutsidePaths(std::string file) : file_(std::move(file)) {}
  void Add(int line, const std::string& message) {
    if (count_++ == 0) {
      first_line_ = line;
      first_message_ = message;
    }
  }
  // Prints the warning, if any.
  void Warn() const {
    if (count_ == 0) return;
    std::string message = first_message_;
    if (count_ > 1) {
      message += " (and " + std::to_string(count_ - 1) + " more image path" +
                 (count_ > 2 ? "s" : "") + " of this file outside it: " + std::to_string(count_) +
                 " in all)";
    }
    std::fprintf(stderr, "warning: %s\n", InputError::Format(file_, first_line_, message).c_str());
  }

 private:
  std::string file_;
  size_t count_ = 0;
  int first_line_ = 0;
  std::string first_message_;
};

std::string ResolveImage(const fs::path& directory, const std::string& file, int line,
                         const std::string& relative, bool refuse_outside, OutsidePaths* outside) {
  const fs::path p = fs::path(relative).is_absolute() ? fs::path(relative) : directory / relative;
  const std::string reason = NotRegularFileReason(p.string());
  if (!reason.empty())
    throw InputError(file, line, "image " + Abbreviate(p.string()) + ": " + reason);
  std::error_code ec;
  if (!fs::is_regular_file(p, ec)) {
    throw InputError(file, line, "image file not found: " + Abbreviate(p.string()));
  }
  const fs::path normal = p.lexically_normal();
  const fs::path base = directory.filename().empty() ? directory.parent_path() : directory;
  const fs::path inside = normal.lexically_relative(base);
  if (inside.empty() || *inside.begin() == "..") {
    const std::string message = "image path " + Abbreviate(relative) +
                                " is outside the dataset folder " + directory.string();
    if (refuse_outside) throw InputError(file, line, message);
    outside->Add(line, message);
  }
  return normal.string();
}

void CheckOrder(const std::string& file, int line, Timestamp previous, Timestamp current,
                bool has_previous) {
  if (!has_previous) return;
  if (current == previous) {
    throw InputError(file, line, "duplicate timestamp " + current.ToString());
  }
  if (current < previous) {
    throw InputError(
        file, line,
        "timestamps not sorted: " + current.ToString() + " after " + previous.ToString());
  }
}

// rgb.txt / depth.txt: "timestamp relative_path".
std::vector<ListEntry> ReadImageList(const fs::path& directory, const std::string& name,
                                     bool refuse_outside) {
  const std::string file = (directory / name).string();
  std::vector<ListEntry> entries;
  OutsidePaths outside(file);
  for (const TextLine& l : ReadDataLines(file)) {
    if (l.tokens.size() != 2) {
      throw InputError(
          file, l.line_number,
          "expected 2 columns 'timestamp path', found " + std::to_string(l.tokens.size()));
    }
    ListEntry e;
    e.line = l.line_number;
    e.stamp = ParseStamp(file, l.line_number, l.tokens[0]);
    CheckOrder(file, l.line_number, entries.empty() ? Timestamp() : entries.back().stamp, e.stamp,
               !entries.empty());
    e.path = ResolveImage(directory, file, l.line_number, l.tokens[1], refuse_outside, &outside);
    entries.push_back(std::move(e));
  }
  if (entries.empty()) throw InputError(file, 0, "no entries");
  outside.Warn();
  return entries;
}

}  // namespace

namespace {

// Images in DIR/`folder` that `list` does not name, as a note ("" when every one is listed): a
// list cut short at a line boundary reads as a shorter sequence, and nothing else tells.
std::string UnlistedImagesNote(const fs::path& dir, const std::string& folder,
                               const std::string& list, const std::vector<ListEntry>& entries) {
  std::error_code ec;
  if (!fs::is_directory(dir / folder, ec)) return "";
  std::set<std::string> listed;
  for (const ListEntry& e : entries) listed.insert(fs::path(e.path).lexically_normal().string());
  size_t images = 0, unlisted = 0;
  for (fs::directory_iterator it(dir / folder, ec), end; !ec && it != end; it.increment(ec)) {
    if (!HasImageExtension(it->path())) continue;
    if (!it->is_regular_file(ec)) continue;
    ++images;
    unlisted += listed.count(it->path().lexically_normal().string()) == 0;
  }
  if (unlisted == 0) return "";
  return (dir / list).string() + " lists " + std::to_string(images - unlisted) + " of the " +
         std::to_string(images) + " images in " + folder + "/ (" + std::to_string(unlisted) +
         " not listed): a list cut short? The run uses the listed images only";
}

// The frames of a dataset folder and how the rgb.txt entries map onto them.
struct DatasetFrames {
  std::vector<RgbdFrameEntry> frames;
  std::vector<std::optional<size_t>> rgb_entry_to_frame;
  size_t num_rgb_entries = 0;
  std::string listing_problem;
};

// From associations.txt ("t_rgb rgb_path t_depth depth_path", sorted by rgb stamp); `rgb`: the
// rgb.txt entries when there is one (entries map onto frames by stamp), else empty.
DatasetFrames FramesFromAssociations(const fs::path& dir, const std::vector<ListEntry>& rgb,
                                     const DatasetOptions& options) {
  const std::string file = (dir / "associations.txt").string();
  OutsidePaths outside(file);
  DatasetFrames out;
  for (const TextLine& l : ReadDataLines(file)) {
    if (l.tokens.size() != 4) {
      throw InputError(file, l.line_number,
                       "expected 4 columns 't_rgb rgb_path t_depth depth_path', found " +
                           std::to_string(l.tokens.size()));
    }
    RgbdFrameEntry f;
    f.rgb_stamp = ParseStamp(file, l.line_number, l.tokens[0]);
    f.depth_stamp = ParseStamp(file, l.line_number, l.tokens[2]);
    CheckOrder(file, l.line_number, out.frames.empty() ? Timestamp() : out.frames.back().rgb_stamp,
               f.rgb_stamp, !out.frames.empty());
    if (std::abs(SecondsBetween(f.rgb_stamp, f.depth_stamp)) >= options.max_time_difference) {
      throw InputError(file, l.line_number,
                       "rgb and depth stamps differ by more than max_time_difference");
    }
    f.rgb_path =
        ResolveImage(dir, file, l.line_number, l.tokens[1], options.refuse_outside_paths, &outside);
    f.depth_path =
        ResolveImage(dir, file, l.line_number, l.tokens[3], options.refuse_outside_paths, &outside);
    f.rgb_listed_at = f.depth_listed_at = file + ":" + std::to_string(l.line_number);
    out.frames.push_back(std::move(f));
  }
  if (out.frames.empty()) throw InputError(file, 0, "no entries");
  outside.Warn();
  if (rgb.empty()) {
    out.num_rgb_entries = out.frames.size();
    for (size_t i = 0; i < out.frames.size(); ++i) out.rgb_entry_to_frame.push_back(i);
    return out;
  }
  std::map<int64_t, size_t> frame_of_stamp;
  for (size_t i = 0; i < out.frames.size(); ++i)
    frame_of_stamp[out.frames[i].rgb_stamp.nanoseconds()] = i;
  out.num_rgb_entries = rgb.size();
  for (const ListEntry& e : rgb) {
    auto it = frame_of_stamp.find(e.stamp.nanoseconds());
    out.rgb_entry_to_frame.push_back(
        it == frame_of_stamp.end() ? std::nullopt : std::optional<size_t>(it->second));
  }
  return out;
}

// From rgb.txt and depth.txt, paired by the nearest stamps within options.max_time_difference.
DatasetFrames FramesFromLists(const fs::path& dir, const std::vector<ListEntry>& rgb,
                              const DatasetOptions& options) {
  DatasetFrames out;
  const std::vector<ListEntry> depth =
      ReadImageList(dir, "depth.txt", options.refuse_outside_paths);
  for (const std::string& note : {UnlistedImagesNote(dir, "rgb", "rgb.txt", rgb),
                                  UnlistedImagesNote(dir, "depth", "depth.txt", depth)}) {
    if (!note.empty()) out.listing_problem += (out.listing_problem.empty() ? "" : "; ") + note;
  }
  std::vector<Timestamp> rgb_stamps, depth_stamps;
  for (const ListEntry& e : rgb) rgb_stamps.push_back(e.stamp);
  for (const ListEntry& e : depth) depth_stamps.push_back(e.stamp);
  const std::vector<TimestampMatch> matches =
      AssociateTimestamps(rgb_stamps, depth_stamps, options.max_time_difference);
  out.num_rgb_entries = rgb.size();
  out.rgb_entry_to_frame.assign(rgb.size(), std::nullopt);
  const std::string rgb_file = (dir / "rgb.txt").string();
  const std::string depth_file = (dir / "depth.txt").string();
  for (const TimestampMatch& m : matches) {
    out.rgb_entry_to_frame[m.first] = out.frames.size();
    out.frames.push_back({rgb[m.first].stamp, rgb[m.first].path, depth[m.second].stamp,
                          depth[m.second].path, rgb_file + ":" + std::to_string(rgb[m.first].line),
                          depth_file + ":" + std::to_string(depth[m.second].line)});
  }
  if (out.frames.empty()) {
    throw InputError(dir.string(), 0,
                     "no rgb/depth pairs within " + std::to_string(options.max_time_difference) +
                         " s (rgb.txt and depth.txt do not overlap in time)");
  }
  return out;
}

}  // namespace

RgbdDataset RgbdDataset::Open(const std::string& directory, const DatasetOptions& options) {
  options.Check();
  std::error_code ec;
  if (!fs::exists(directory, ec)) throw InputError(directory, 0, "dataset directory not found");
  if (!fs::is_directory(directory, ec)) throw InputError(directory, 0, "not a directory");
  const fs::path dir = fs::absolute(directory).lexically_normal();
  const bool use_assoc =
      options.use_associations_file && fs::is_regular_file(dir / "associations.txt", ec);
  const bool has_rgb_list = fs::is_regular_file(dir / "rgb.txt", ec);
  std::vector<ListEntry> rgb;
  if (has_rgb_list || !use_assoc) rgb = ReadImageList(dir, "rgb.txt", options.refuse_outside_paths);
  DatasetFrames frames =
      use_assoc ? FramesFromAssociations(dir, rgb, options) : FramesFromLists(dir, rgb, options);
  RgbdDataset dataset;
  dataset.directory_ = dir.string();
  dataset.frames_ = std::move(frames.frames);
  dataset.rgb_entry_to_frame_ = std::move(frames.rgb_entry_to_frame);
  dataset.num_rgb_entries_ = frames.num_rgb_entries;
  dataset.listing_problem_ = std::move(frames.listing_problem);
  const fs::path gt = dir / "groundtruth.txt";
  if (fs::is_regular_file(gt, ec)) {
    dataset.groundtruth_path_ = gt.string();
  } else if (const std::string reason = NotRegularFileReason(gt.string()); !reason.empty()) {
    dataset.groundtruth_problem_ = gt.string() + ": " + reason;
  }
  return dataset;
}

std::string GroundTruthCoverageNote(const RgbdDataset& dataset, size_t first, size_t last,
                                    const std::vector<StampedPose>& groundtruth,
                                    double tolerance_s) {
  if (groundtruth.empty()) return "";
  const Timestamp begin = groundtruth.front().stamp, end = groundtruth.back().stamp;
  size_t frames = 0, before = 0, after = 0, in_gaps = 0;
  for (size_t k = first; k < last; ++k) {
    const std::optional<size_t> i = dataset.FrameForRgbEntry(k);
    if (!i) continue;
    ++frames;
    const Timestamp t = dataset.frame(*i).rgb_stamp;
    if (SecondsBetween(t, begin) > tolerance_s) {
      ++before;
    } else if (SecondsBetween(end, t) > tolerance_s) {
      ++after;
    } else {
      // The nearest pose: the first at or after t, or the one before it.
      const auto next =
          std::lower_bound(groundtruth.begin(), groundtruth.end(), t,
                           [](const StampedPose& p, Timestamp stamp) { return p.stamp < stamp; });
      double nearest = std::numeric_limits<double>::infinity();
      if (next != groundtruth.end()) nearest = std::abs(SecondsBetween(t, next->stamp));
      if (next != groundtruth.begin())
        nearest = std::min(nearest, std::abs(SecondsBetween(std::prev(next)->stamp, t)));
      in_gaps += nearest > tolerance_s;
    }
  }
  if (before + after + in_gaps == 0) return "";
  char text[500];
  std::snprintf(text, sizeof(text),
                "covers %.1f s (%s to %s); %zu of the %zu frames have no pose of it within %g s "
                "(%zu before it, %zu after it, %zu in its gaps): a ground truth cut short or with "
                "holes? The ATE covers the other frames",
                SecondsBetween(begin, end), begin.ToString().c_str(), end.ToString().c_str(),
                before + after + in_gaps, frames, tolerance_s, before, after, in_gaps);
  return dataset.groundtruth_path() + " " + text;
}

std::string ImplausibleGroundTruthNote(const std::string& path,
                                       const std::vector<StampedPose>& groundtruth) {
  for (size_t i = 1; i < groundtruth.size(); ++i) {
    const double dt = SecondsBetween(groundtruth[i - 1].stamp, groundtruth[i].stamp);
    const double distance =
        (groundtruth[i].world_from_cam.translation - groundtruth[i - 1].world_from_cam.translation)
            .norm();
    if (dt > 0 && distance > kMaxGroundTruthSpeed * std::max(dt, 0.01)) {
      char text[400];
      std::snprintf(text, sizeof(text),
                    ": the pose at %s s is %g m from the one %.3f s before it (%g m/s; a camera "
                    "moves a few m/s): another unit (millimetres?) or a corrupt line? The ATE "
                    "against it would mean nothing",
                    groundtruth[i].stamp.ToString().c_str(), distance, dt, distance / dt);
      return path + text;
    }
  }
  return "";
}

std::optional<size_t> RgbdDataset::FrameForRgbEntry(size_t k) const {
  if (k >= rgb_entry_to_frame_.size()) return std::nullopt;
  return rgb_entry_to_frame_[k];
}

Timestamp RgbdDataset::StampOfRgbEntry(size_t k) const {
  for (size_t e = k; e < num_rgb_entries(); ++e) {
    if (const auto index = FrameForRgbEntry(e)) return frames_[*index].rgb_stamp;
  }
  if (frames_.empty()) return Timestamp();
  return Timestamp::FromNanoseconds(frames_.back().rgb_stamp.nanoseconds() + 1);
}

namespace {

const char* TypeName(int type) {
  switch (type) {
    case CV_8UC1:
      return "8-bit 1-channel";
    case CV_8UC3:
      return "8-bit 3-channel";
    case CV_8UC4:
      return "8-bit 4-channel";
    case CV_16UC1:
      return "16-bit 1-channel";
    case CV_16UC3:
      return "16-bit 3-channel";
    case CV_16UC4:
      return "16-bit 4-channel";
    case CV_32FC1:
      return "32-bit float 1-channel";
    default:
      return "unsupported pixel type";
  }
}

// Width and height from a PNG's IHDR chunk (bytes 16..23, big endian); false if `path` is not a
// PNG or does not start with an IHDR chunk.
bool PngSize(const std::string& path, int64_t* width, int64_t* height) {
  std::ifstream in(path, std::ios::binary);
  unsigned char header[24];
  if (!in.read(reinterpret_cast<char*>(header), sizeof(header))) return false;
  static const unsigned char kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (!std::equal(kSignature, kSignature + 8, header)) return false;
  // The IHDR chunk must come first; without it the header says nothing (the decoder reports it).
  if (header[12] != 'I' || header[13] != 'H' || header[14] != 'D' || header[15] != 'R')
    return false;
  const auto be32 = [&](int at) {
    return (int64_t{header[at]} << 24) | (int64_t{header[at + 1]} << 16) |
           (int64_t{header[at + 2]} << 8) | int64_t{header[at + 3]};
  };
  *width = be32(16);
  *height = be32(20);
  return true;
}

// `listed_at`: "rgb.txt:12", named in every message next to the image.
cv::Mat LoadImage(const std::string& path, const std::string& listed_at, int expected_type,
                  const char* what, int width, int height) {
  const auto fail = [&](const std::string& message) {
    throw InputError(path, 0,
                     message + (listed_at.empty() ? "" : " (listed at " + listed_at + ")"));
  };
  std::error_code ec;
  const std::string reason = NotRegularFileReason(path);
  if (!reason.empty()) fail(std::string(what) + " image " + reason);
  if (!fs::is_regular_file(path, ec)) fail(std::string(what) + " image not found");
  // The size first, from the header: decoding a 20000x20000 PNG allocates 1.2 GB before its size
  // could be checked, and OpenCV refuses larger ones with an assertion.
  int64_t png_width = 0, png_height = 0;
  if (PngSize(path, &png_width, &png_height)) {
    const int64_t max_side = 16384;  // Camera.width / height limit
    if ((width > 0 && png_width != width) || (height > 0 && png_height != height) ||
        png_width > max_side || png_height > max_side || png_width <= 0 || png_height <= 0) {
      fail(std::string(what) + " image is " + std::to_string(png_width) + "x" +
           std::to_string(png_height) + ", expected " +
           (width > 0 ? std::to_string(width) + "x" + std::to_string(height)
                      : "at most " + std::to_string(max_side) + "x" + std::to_string(max_side)) +
           " (size from the PNG header; not decoded)");
    }
  }
  cv::Mat image;
  try {
    // The common layouts with libdeflate (png_reader.h: same pixels, ~half the CPU); the rest
    // and any problem with OpenCV, which reports it.
    if (!ReadPngFast(path, &image)) image = cv::imread(path, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    fail(std::string("cannot decode ") + what + " image: " + e.err);
  }
  if (image.empty())
    fail(std::string("cannot decode ") + what + " image (corrupt or not an image)");
  if (image.type() != expected_type) {
    fail(std::string(what) + " image must be " + TypeName(expected_type) + ", found " +
         TypeName(image.type()));
  }
  if ((width > 0 && image.cols != width) || (height > 0 && image.rows != height)) {
    fail(std::string(what) + " image is " + std::to_string(image.cols) + "x" +
         std::to_string(image.rows) + ", expected " + std::to_string(width) + "x" +
         std::to_string(height));
  }
  return image;
}

}  // namespace

cv::Mat RgbdDataset::LoadRgb(size_t i, int expected_width, int expected_height) const {
  return LoadImage(frame(i).rgb_path, frame(i).rgb_listed_at, CV_8UC3, "rgb", expected_width,
                   expected_height);
}

cv::Mat RgbdDataset::LoadDepth(size_t i, int expected_width, int expected_height) const {
  return LoadImage(frame(i).depth_path, frame(i).depth_listed_at, CV_16UC1, "depth", expected_width,
                   expected_height);
}

FrameRangeText SplitFrameRange(const std::string& text) {
  const auto colon = text.find(':');
  if (colon == std::string::npos)
    throw InvalidOptions("--frames: expected FIRST:LAST, got '" + Abbreviate(text) + "'");
  auto parse = [&](const std::string& s) -> std::optional<size_t> {
    if (s.empty()) return std::nullopt;
    if (s.size() > 12) throw InvalidOptions("--frames: number too large: '" + Abbreviate(s) + "'");
    const std::optional<int64_t> value = ParseWholeInteger(s);
    if (!value || *value < 0)
      throw InvalidOptions("--frames: not a non-negative integer: '" + Abbreviate(s) + "'");
    return static_cast<size_t>(*value);
  };
  return {parse(text.substr(0, colon)), parse(text.substr(colon + 1))};
}

std::pair<size_t, size_t> ParseFrameRange(const std::string& text, size_t total,
                                          std::string* note) {
  if (note != nullptr) note->clear();
  const FrameRangeText sides = SplitFrameRange(text);
  const size_t first = sides.first.value_or(0);
  const size_t asked = sides.last.value_or(total);
  const size_t last = std::min(asked, total);
  if (first >= last) {
    // Which range, and why it is empty: beyond the dataset (with its size) or FIRST >= LAST.
    const std::string range = "'" + Abbreviate(text) + "' (rgb.txt entries " +
                              std::to_string(first) + " to " + std::to_string(asked) + ")";
    if (first >= total)
      throw InvalidOptions("--frames: empty range " + range + ": FIRST " + std::to_string(first) +
                           " is beyond the dataset's " + std::to_string(total) +
                           " rgb.txt entries (0.." + std::to_string(total == 0 ? 0 : total - 1) +
                           ")");
    throw InvalidOptions("--frames: empty range " + range + ": FIRST must be below LAST (the " +
                         "dataset has " + std::to_string(total) + " rgb.txt entries)");
  }
  if (asked > total && note != nullptr) {
    *note = "--frames '" + Abbreviate(text) + "': LAST " + std::to_string(asked) +
            " is beyond the " + std::to_string(total) + " rgb.txt entries; using " +
            std::to_string(first) + ":" + std::to_string(total);
  }
  return {first, last};
}

DepthRangeSample SampleDepthRange(const RgbdDataset& dataset, size_t first, size_t last,
                                  double depth_map_factor, int width, int height,
                                  size_t max_images) {
  DepthRangeSample sample;
  std::vector<size_t> frames;
  for (size_t k = first; k < last; ++k) {
    if (const auto index = dataset.FrameForRgbEntry(k)) frames.push_back(*index);
  }
  if (frames.empty() || max_images == 0) return sample;
  const size_t n = std::min(max_images, frames.size());
  std::vector<float> depths;
  for (size_t j = 0; j < n; ++j) {
    const size_t index = frames[n == 1 ? 0 : j * (frames.size() - 1) / (n - 1)];
    const cv::Mat raw = dataset.LoadDepth(index, width, height);
    if (sample.example.empty()) sample.example = dataset.frame(index).depth_path;
    ++sample.images;
    for (int y = 0; y < raw.rows; ++y) {
      const uint16_t* row = raw.ptr<uint16_t>(y);
      for (int x = 0; x < raw.cols; ++x) {
        if (row[x] == 0) continue;
        const double metres = row[x] / depth_map_factor;
        ++sample.valid;
        if (metres > kMaxSensorDepthMetres) ++sample.beyond;
        if (metres < kMinSensorDepthMetres) ++sample.below;
        if ((x + y) % 7 == 0) depths.push_back(static_cast<float>(metres));
      }
    }
  }
  if (!depths.empty()) {
    std::nth_element(depths.begin(), depths.begin() + depths.size() / 2, depths.end());
    sample.median_m = depths[depths.size() / 2];
  }
  return sample;
}

std::string ImplausibleDepth(const DepthRangeSample& s, double depth_map_factor) {
  if (s.valid == 0) return "";
  const bool beyond = s.beyond * 2 > s.valid, below = s.below * 2 > s.valid;
  const char* causes =
      "Likely causes: DepthMapFactor off by an order of magnitude or more (raw / DepthMapFactor = "
      "metres: 5000 for TUM and Bonn, 1000 for millimetres)";
  char text[700];
  if (!beyond && !below) {
    if (s.median_m >= kMinPlausibleMedianDepthMetres) return "";
    std::snprintf(text, sizeof(text),
                  "the median depth of %zu sampled depth images (e.g. %s) is %.4g m with "
                  "DepthMapFactor %g: closer than %g m, surfaces within arm's reach in every "
                  "image. %s",
                  s.images, EchoValue(s.example, 300).c_str(), s.median_m, depth_map_factor,
                  kMinPlausibleMedianDepthMetres, causes);
    return text;
  }
  std::snprintf(
      text, sizeof(text),
      "%.0f %% of the depth pixels of %zu sampled depth images (e.g. %s) lie %s m "
      "(median %.4g m with DepthMapFactor %g): outside the range of an RGB-D sensor "
      "(%g to %g m). %s%s",
      100.0 * (beyond ? s.beyond : s.below) / s.valid, s.images, EchoValue(s.example, 300).c_str(),
      beyond ? ("beyond " + std::to_string(static_cast<int>(kMaxSensorDepthMetres))).c_str()
             : "closer than 0.05",
      s.median_m, depth_map_factor, kMinSensorDepthMetres, kMaxSensorDepthMetres, causes,
      beyond ? ", or depth images saturated at their largest value (invalid depth)" : "");
  return text;
}

std::string FindOutputOnDatasetImage(const RgbdDataset& dataset, const std::string& dataset_dir,
                                     const std::vector<NamedPath>& outputs) {
  std::vector<NamedPath> images;
  images.reserve(2 * dataset.frames().size());
  for (const RgbdFrameEntry& f : dataset.frames()) {
    images.push_back({"the dataset's image listed at " + f.rgb_listed_at, f.rgb_path});
    images.push_back({"the dataset's image listed at " + f.depth_listed_at, f.depth_path});
  }
  // And every file in its image folders (entries without a partner are not in frames()).
  for (const char* folder : {"rgb", "depth"}) {
    std::error_code ec;
    for (std::filesystem::directory_iterator it(std::filesystem::path(dataset_dir) / folder, ec),
         end;
         !ec && it != end; it.increment(ec))
      images.push_back(
          {std::string("a file of the dataset's ") + folder + "/ folder", it->path().string()});
  }
  return FindOutputAmongInputs(images, outputs);
}

bool HasImageExtension(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg";
}

bool IsDatasetFolder(const std::filesystem::path& dir) {
  namespace fs = std::filesystem;
  std::error_code ec;
  return (fs::is_regular_file(dir / "rgb.txt", ec) && fs::is_regular_file(dir / "depth.txt", ec)) ||
         fs::is_regular_file(dir / "associations.txt", ec);
}

std::string DatasetImageFolderOf(const std::filesystem::path& dir) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const auto holds_image = [&](const fs::path& folder) {
    int looked = 0;
    for (fs::directory_iterator it(folder, ec), end; !ec && it != end && looked < 200;
         it.increment(ec), ++looked) {
      if (HasImageExtension(it->path())) return true;
    }
    return false;
  };
  // Through links too: a link to a dataset's rgb/ is that folder.
  fs::path absolute = fs::weakly_canonical(fs::absolute(dir, ec), ec);
  if (ec) absolute = fs::absolute(dir, ec).lexically_normal();
  for (fs::path a = absolute; a.has_relative_path(); a = a.parent_path()) {
    const std::string name = a.filename().string();
    if (name.empty() || !IsDatasetFolder(a.parent_path())) continue;
    if (name == "rgb" || name == "depth" || name == "mask" ||
        (fs::is_directory(a, ec) && holds_image(a)))
      return a.string();
  }
  return "";
}

std::string DatasetFolderOf(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::exists(path, ec)) return "";
  const fs::path folder = fs::absolute(path, ec).parent_path();
  for (const fs::path& dir : {folder, folder.parent_path()})
    if (IsDatasetFolder(dir)) return dir.string();
  return "";
}

}  // namespace dygslam
