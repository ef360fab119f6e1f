#include "run/dataset_runner.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <exception>
#include <filesystem>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "core/base/error.h"
#include "core/base/log.h"
#include "core/base/stop_signal.h"
#include "core/base/thread_setup.h"
#include "core/io/detections_io.h"

namespace dygslam {

void DatasetRunOptions::Check() const {
  DYGSLAM_CHECK_OPTION(first_entry <= last_entry, "dataset_run.first_entry <= last_entry");
  DYGSLAM_CHECK_OPTION(image_width >= 0 && image_height >= 0, "dataset_run.image_width/height");
  DYGSLAM_CHECK_OPTION(rate >= 0 && rate <= 1000, "--rate (0..1000)");
  DYGSLAM_CHECK_OPTION(decode_ahead >= 1 && decode_ahead <= 64, "dataset_run.decode_ahead");
}

namespace {

// A frame read by the loader thread: its images, or the error that reading them raised, or
// `skipped` for an entry without a depth partner.
struct LoadedFrame {
  size_t entry = 0;
  bool skipped = false;
  cv::Mat rgb, depth;
  Timestamp stamp;
  std::exception_ptr error;
};

// Reads rgb.txt entries [first, last) in order on its own thread, at most `capacity` ahead of
// the consumer; Stop() ends it early.
class FrameLoader {
 public:
  FrameLoader(const RgbdDataset& dataset, const DatasetRunOptions& options)
      : dataset_(dataset), options_(options), capacity_(std::max(1, options.decode_ahead)) {
    thread_ = std::thread([this] {
      SetCurrentThreadName("frame loader");
      Load();
    });
  }
  ~FrameLoader() { Stop(); }
  FrameLoader(const FrameLoader&) = delete;
  FrameLoader& operator=(const FrameLoader&) = delete;

  // The next frame in entry order; nullopt after the last one.
  std::optional<LoadedFrame> Pop() {
    std::unique_lock<std::mutex> lock(mutex_);
    changed_.wait(lock, [this] { return !queue_.empty() || done_; });
    if (queue_.empty()) return std::nullopt;
    LoadedFrame f = std::move(queue_.front());
    queue_.pop_front();
    changed_.notify_all();
    return f;
  }
  // The frame Pop() will return next, waiting for it; nullptr after the last one. Valid until
  // the next Pop().
  const LoadedFrame* Peek() {
    std::unique_lock<std::mutex> lock(mutex_);
    changed_.wait(lock, [this] { return !queue_.empty() || done_; });
    return queue_.empty() ? nullptr : &queue_.front();
  }
  void Stop() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    changed_.notify_all();
    if (thread_.joinable()) thread_.join();
  }

 private:
  void Load() {
    for (size_t k = options_.first_entry; k < options_.last_entry; ++k) {
      {
        std::unique_lock<std::mutex> lock(mutex_);
        changed_.wait(lock, [this] { return stop_ || queue_.size() < capacity_; });
        if (stop_) break;
      }
      LoadedFrame f;
      f.entry = k;
      const auto index = dataset_.FrameForRgbEntry(k);
      if (!index) {
        f.skipped = true;
      } else {
        try {
          f.rgb = dataset_.LoadRgb(*index, options_.image_width, options_.image_height);
          f.depth = dataset_.LoadDepth(*index, options_.image_width, options_.image_height);
          f.stamp = Timestamp::FromNanoseconds(dataset_.frame(*index).rgb_stamp.nanoseconds() +
                                               options_.stamp_offset_ns);
        } catch (...) {
          f.error = std::current_exception();
        }
      }
      const bool failed = f.error != nullptr;
      {
        std::lock_guard<std::mutex> lock(mutex_);
        queue_.push_back(std::move(f));
      }
      changed_.notify_all();
      if (failed) break;  // nothing after a bad frame is fed
    }
    std::lock_guard<std::mutex> lock(mutex_);
    done_ = true;
    changed_.notify_all();
  }

  const RgbdDataset& dataset_;
  const DatasetRunOptions& options_;
  const size_t capacity_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<LoadedFrame> queue_;
  bool done_ = false;
  bool stop_ = false;
  std::thread thread_;  // last: it uses everything above
};

// When each frame of a paced replay arrives, as from a camera: its stamp's offset from the first
// frame's, over the rate, after the first frame arrived (the camera starts with it, once it is
// loaded). The start moves later by the time this process was stopped (SIGSTOP, Ctrl-Z): the
// camera of a paused replay is paused too, so its frames are not the pipeline's drops.
class ReplayClock {
 public:
  using Clock = std::chrono::steady_clock;
  explicit ReplayClock(double rate) : rate_(rate), continued_seen_(TimesContinued()) {}

  Clock::time_point Arrival(Timestamp stamp) {
    if (!first_stamp_) {
      first_stamp_ = stamp;
      start_ = Clock::now();
    }
    const double s = SecondsBetween(*first_stamp_, stamp) / rate_;
    return start_ + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
  }
  // After a stop of this process: the replay goes on from the frame `stamp` (rgb.txt `entry`),
  // due now.
  void ResumeAfterStop(Timestamp stamp, size_t entry) {
    if (TimesContinued() == continued_seen_) return;
    continued_seen_ = TimesContinued();
    if (const auto behind = Clock::now() - Arrival(stamp); behind > Clock::duration::zero()) {
      start_ += behind;
      LOG_INFO << "run: stopped and continued; the replay goes on at the camera's rate from "
                  "rgb.txt entry "
               << entry;
    }
  }

 private:
  double rate_;
  Clock::time_point start_;
  unsigned continued_seen_;
  std::optional<Timestamp> first_stamp_;
};

}  // namespace

DatasetRunSummary RunDatasetFrames(const RgbdDataset& dataset, System& system,
                                   const DatasetRunOptions& options,
                                   const FrameCallback& on_frame) {
  options.Check();
  if (options.last_entry > dataset.num_rgb_entries()) {
    throw InvalidOptions("frame range: last entry " + std::to_string(options.last_entry) +
                         " beyond the " + std::to_string(dataset.num_rgb_entries()) +
                         " rgb.txt entries of " + dataset.directory());
  }
  const bool prefetch = options.prefetch_detections && options.detections == nullptr;
  const bool paced = options.rate > 0;
  using Clock = std::chrono::steady_clock;
  DatasetRunSummary summary;
  const auto t0 = Clock::now();
  ReplayClock camera(options.rate);
  auto arrival = [&](const LoadedFrame& f) { return camera.Arrival(f.stamp); };
  FrameLoader loader(dataset, options);
  std::optional<Timestamp> prefetched;  // the stamp whose detection was started ahead
  while (true) {
    if (options.stop && options.stop()) {
      summary.interrupted = loader.Peek() != nullptr;
      break;
    }
    std::optional<LoadedFrame> frame = loader.Pop();
    if (!frame) break;
    if (frame->skipped) {
      ++summary.skipped;
      continue;
    }
    if (frame->error) std::rethrow_exception(frame->error);
    Clock::time_point arrived = Clock::now();
    if (paced) {
      camera.ResumeAfterStop(frame->stamp, frame->entry);
      std::this_thread::sleep_until(arrival(*frame));
      camera.ResumeAfterStop(frame->stamp, frame->entry);  // stopped while it waited for it
      arrived = arrival(*frame);
      // A camera's queue of one: newer frames that have arrived replace this one.
      for (const LoadedFrame* next = loader.Peek();
           next && !next->skipped && !next->error && arrival(*next) <= Clock::now();
           next = loader.Peek()) {
        ++summary.dropped;
        frame = loader.Pop();
        arrived = arrival(*frame);
      }
    }
    if (prefetch) {
      // The next frame's detection starts now, overlapping this frame's tracking (paced: only
      // once it has arrived).
      const LoadedFrame* next = loader.Peek();
      if (next && !next->skipped && !next->error && (!paced || arrival(*next) <= Clock::now()) &&
          prefetched != next->stamp) {
        system.PrefetchDetections(next->rgb, next->stamp);
        prefetched = next->stamp;
      }
    }
    const FrameResult r =
        options.detections != nullptr
            ? system.FeedRgbdFrame(frame->rgb, frame->depth, frame->stamp, cv::Mat(),
                                   &DetectionsNear(*options.detections, frame->stamp))
            : system.FeedRgbdFrame(frame->rgb, frame->depth, frame->stamp);
    ++summary.processed;
    if (paced) {
      const auto now = Clock::now();
      summary.latencies.push_back(
          {frame->stamp, std::chrono::duration<double, std::milli>(now - arrived).count()});
    }
    if (r.state == TrackingState::kLost) ++summary.lost;
    if (on_frame) on_frame(frame->entry, r);
  }
  summary.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
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
