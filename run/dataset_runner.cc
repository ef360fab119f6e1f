#include "run/dataset_runner.h"

#include <chrono>
#include <exception>
#include <filesystem>
#include <string>

#include "core/base/error.h"
#include "core/io/detections_io.h"

namespace dygslam {

void DatasetRunOptions::Check() const {
  DYGSLAM_CHECK_OPTION(first_entry <= last_entry, "dataset_run.first_entry <= last_entry");
  DYGSLAM_CHECK_OPTION(image_width >= 0 && image_height >= 0, "dataset_run.image_width/height");
}

DatasetRunSummary RunDatasetFrames(const RgbdDataset& dataset, System& system,
                                   const DatasetRunOptions& options,
                                   const FrameCallback& on_frame) {
  options.Check();
  if (options.last_entry > dataset.num_rgb_entries()) {
    throw InvalidOptions("frame range: last entry " + std::to_string(options.last_entry) +
                         " beyond the " + std::to_string(dataset.num_rgb_entries()) +
                         " rgb.txt entries of " + dataset.directory());
  }
  const int width = options.image_width;
  const int height = options.image_height;
  const bool prefetch = options.prefetch_detections && options.detections == nullptr;
  auto stamp_of = [&](size_t index) {
    return Timestamp::FromNanoseconds(dataset.frame(index).rgb_stamp.nanoseconds() +
                                      options.stamp_offset_ns);
  };
  DatasetRunSummary summary;
  const auto t0 = std::chrono::steady_clock::now();
  cv::Mat next_rgb;  // loaded one frame ahead so its detection overlaps this frame's tracking
  // A bad next image is reported when its own turn comes: the frames before it are all fed.
  std::exception_ptr next_error;
  for (size_t k = options.first_entry; k < options.last_entry; ++k) {
    if (options.stop && options.stop()) {
      summary.interrupted = true;
      break;
    }
    if (next_error) std::rethrow_exception(next_error);
    const auto index = dataset.FrameForRgbEntry(k);
    if (!index) {
      ++summary.skipped;
      continue;
    }
    const cv::Mat rgb = next_rgb.empty() ? dataset.LoadRgb(*index, width, height) : next_rgb;
    next_rgb = cv::Mat();
    const cv::Mat depth = dataset.LoadDepth(*index, width, height);
    const Timestamp stamp = stamp_of(*index);
    if (prefetch && k + 1 < options.last_entry) {
      if (const auto next = dataset.FrameForRgbEntry(k + 1)) {
        try {
          next_rgb = dataset.LoadRgb(*next, width, height);
          system.PrefetchDetections(next_rgb, stamp_of(*next));
        } catch (const InputError&) {
          next_rgb = cv::Mat();
          next_error = std::current_exception();
        }
      }
    }
    const FrameResult r = options.detections != nullptr
                              ? system.FeedRgbdFrame(rgb, depth, stamp, cv::Mat(),
                                                     &DetectionsNear(*options.detections, stamp))
                              : system.FeedRgbdFrame(rgb, depth, stamp);
    ++summary.processed;
    if (r.state == TrackingState::kLost) ++summary.lost;
    if (on_frame) on_frame(k, r);
  }
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return summary;
}

std::map<Timestamp, std::vector<Detection>> ShippedDetections(const RgbdDataset& dataset,
                                                              const SystemOptions& options,
                                                              bool* found) {
  const std::string path = dataset.directory() + "/detections.txt";
  std::error_code ec;
  *found = options.NeedsDetections() && std::filesystem::is_regular_file(path, ec);
  if (!*found) return {};
  return ReadDetections(path);
}

}  // namespace dygslam
