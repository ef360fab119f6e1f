#include "bridge/rgbd_sync.h"

#include <cmath>
#include <cstdlib>

#include "core/base/error.h"

namespace dygslam::ros2 {

void RgbdSyncOptions::Check() const {
  DYGSLAM_CHECK_OPTION(max_stamp_difference_s >= 0 && std::isfinite(max_stamp_difference_s),
                       "max_stamp_difference_s");
  DYGSLAM_CHECK_OPTION(max_queue >= 1, "sync max_queue");
}

RgbdSynchronizer::RgbdSynchronizer(const RgbdSyncOptions& options) : options_(options) {
  options_.Check();
  tolerance_ns_ = static_cast<int64_t>(std::llround(options.max_stamp_difference_s * 1e9));
}

std::vector<RgbdFrame> RgbdSynchronizer::AddColor(StampedImage color) {
  return Add(std::move(color), &colors_, &last_color_, &stats_.dropped_color);
}

std::vector<RgbdFrame> RgbdSynchronizer::AddDepth(StampedImage depth) {
  return Add(std::move(depth), &depths_, &last_depth_, &stats_.dropped_depth);
}

std::vector<RgbdFrame> RgbdSynchronizer::Add(StampedImage image, std::deque<StampedImage>* queue,
                                             std::optional<Timestamp>* last, size_t* dropped) {
  if (*last && image.stamp <= **last) {
    ++*dropped;
    return {};
  }
  *last = image.stamp;
  queue->push_back(std::move(image));
  if (queue->size() > options_.max_queue) {
    queue->pop_front();
    ++*dropped;
  }
  return Match();
}

std::vector<RgbdFrame> RgbdSynchronizer::Match() {
  std::vector<RgbdFrame> out;
  while (!colors_.empty() && !depths_.empty()) {
    const int64_t tc = colors_.front().stamp.nanoseconds();
    size_t best = 0;
    int64_t best_diff = -1;
    bool final_choice = false;
    for (size_t i = 0; i < depths_.size(); ++i) {
      const int64_t diff = std::llabs(depths_[i].stamp.nanoseconds() - tc);
      if (best_diff < 0 || diff < best_diff) {
        best = i;
        best_diff = diff;
      }
      if (depths_[i].stamp.nanoseconds() >= tc) {
        final_choice = true;  // later depths are further from this colour
        break;
      }
    }
    if (!final_choice) {
      // Every queued depth is older than the colour: the nearest so far is the newest one; it
      // may still be beaten by a depth to come, unless it is already exact.
      if (best_diff == 0) final_choice = true;
    }
    if (!final_choice) break;  // wait for more depth
    if (best_diff > tolerance_ns_) {
      // The best partner is out of tolerance: the colour cannot be paired any more.
      colors_.pop_front();
      ++stats_.dropped_color;
      continue;
    }
    // Depths older than the chosen one cannot serve later colours better.
    for (size_t i = 0; i < best; ++i) {
      depths_.pop_front();
      ++stats_.dropped_depth;
    }
    RgbdFrame frame;
    frame.stamp = colors_.front().stamp;
    frame.rgb = std::move(colors_.front().image);
    frame.depth = std::move(depths_.front().image);
    frame.depth_scale = depths_.front().depth_scale;
    colors_.pop_front();
    depths_.pop_front();
    ++stats_.pairs;
    out.push_back(std::move(frame));
  }
  return out;
}

}  // namespace dygslam::ros2
