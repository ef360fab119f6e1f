#include "mapping/keyframe_mapper.h"

#include <algorithm>
#include <chrono>

#include "core/base/error.h"
#include "core/base/thread_setup.h"

namespace dygslam {
namespace {

double MsBetween(std::chrono::steady_clock::time_point a, std::chrono::steady_clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

KeyframeData DeepCopy(const KeyframeData& in) {
  KeyframeData out = in;  // scalars, vectors
  out.rgb = cv::Mat();    // the map reads depth and mask only
  out.depth = in.depth.clone();
  out.dynamic_mask = in.dynamic_mask.clone();
  return out;
}

}  // namespace

void KeyframeMapperOptions::Check() const {
  DYGSLAM_CHECK_OPTION(max_queue >= 1, "KeyframeMapper.max_queue");
  DYGSLAM_CHECK_OPTION(max_rebuild_share >= 0 && max_rebuild_share <= 1,
                       "KeyframeMapper.max_rebuild_share");
}

KeyframeMapper::KeyframeMapper(const PinholeCamera& camera, const OctoMapOptions& options,
                               const KeyframeMapperOptions& mapper_options)
    : mapper_options_(mapper_options), consumer_(camera, options) {
  mapper_options_.Check();
  worker_ = std::thread([this] {
    SetCurrentThreadName("mapper");
    // The map has no deadline: on a busy machine it takes the CPU time that tracking leaves.
    LowerCurrentThreadPriority();
    Run();
  });
}

KeyframeMapper::~KeyframeMapper() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  changed_.notify_all();
  if (worker_.joinable()) worker_.join();
}

void KeyframeMapper::RethrowIfFailed() {
  if (error_) {
    std::exception_ptr e = error_;
    error_ = nullptr;
    std::rethrow_exception(e);
  }
}

void KeyframeMapper::Submit(const KeyframeData& keyframe) {
  if (ChangeOf(keyframe) == KeyframeChange::kPoseUpdate) {
    // Local BA corrects the same keyframes again and again: a correction still waiting in the
    // queue takes the newer pose instead of queueing another one (same result, no burst).
    std::lock_guard<std::mutex> lock(mutex_);
    for (auto it = queue_.rbegin(); it != queue_.rend(); ++it) {
      if (it->keyframe.id != keyframe.id) continue;
      if (ChangeOf(it->keyframe) != KeyframeChange::kPoseUpdate) break;  // keep the order
      it->keyframe.world_from_cam = keyframe.world_from_cam;
      ++stats_.num_submitted;
      ++stats_.num_coalesced;
      return;
    }
  }
  Item item{DeepCopy(keyframe), std::chrono::steady_clock::now()};
  std::unique_lock<std::mutex> lock(mutex_);
  if (queue_.size() >= mapper_options_.max_queue) {
    ++stats_.num_blocked;
    changed_.wait(lock, [this] { return queue_.size() < mapper_options_.max_queue || stop_; });
  }
  queue_.push_back(std::move(item));
  ++stats_.num_submitted;
  stats_.max_queue_depth = std::max(stats_.max_queue_depth, queue_.size());
  lock.unlock();
  changed_.notify_all();
}

void KeyframeMapper::Flush() {
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait(lock, [this] { return (queue_.empty() && !busy_) || error_ != nullptr; });
  RethrowIfFailed();
}

void KeyframeMapper::WithBuilder(const std::function<void(OctoMapBuilder&)>& fn) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    RethrowIfFailed();
  }
  std::lock_guard<std::mutex> builder_lock(builder_mutex_);
  fn(consumer_.builder());
}

MapperStats KeyframeMapper::Stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  MapperStats stats = stats_;
  if (!latencies_ms_.empty()) {
    std::vector<double> sorted = latencies_ms_;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    stats.median_latency_ms = sorted[sorted.size() / 2];
    stats.max_latency_ms = *std::max_element(latencies_ms_.begin(), latencies_ms_.end());
  }
  return stats;
}

double KeyframeMapper::MaybeRebuild() {
  std::lock_guard<std::mutex> builder_lock(builder_mutex_);
  if (!consumer_.builder().rebuild_pending()) return -1;
  const auto now = std::chrono::steady_clock::now();
  if (last_rebuild_ms_ > 0 &&
      MsBetween(last_rebuild_end_, now) < last_rebuild_ms_ / mapper_options_.max_rebuild_share) {
    return -1;
  }
  try {
    consumer_.builder().Sync();
  } catch (...) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!error_) error_ = std::current_exception();
  }
  last_rebuild_end_ = std::chrono::steady_clock::now();
  last_rebuild_ms_ = std::max(MsBetween(now, last_rebuild_end_), 1e-3);
  return last_rebuild_ms_;
}

void KeyframeMapper::Run() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (true) {
    changed_.wait(lock, [this] { return !queue_.empty() || stop_; });
    if (queue_.empty()) return;  // stop_ and drained
    Item item = std::move(queue_.front());
    queue_.pop_front();
    busy_ = true;
    lock.unlock();
    changed_.notify_all();  // space in the queue

    const auto start = std::chrono::steady_clock::now();
    std::exception_ptr error;
    try {
      std::lock_guard<std::mutex> builder_lock(builder_mutex_);
      consumer_.Apply(item.keyframe);
    } catch (...) {
      error = std::current_exception();
    }
    const auto end = std::chrono::steady_clock::now();

    lock.lock();
    if (error && !error_) error_ = error;
    ++stats_.num_applied;
    stats_.worker_busy_ms += MsBetween(start, end);
    switch (ChangeOf(item.keyframe)) {
      case KeyframeChange::kRemoved:
        ++stats_.num_removals;
        break;
      case KeyframeChange::kPoseUpdate:
        ++stats_.num_pose_updates;
        break;
      case KeyframeChange::kNew:
        ++stats_.num_new_keyframes;
        latencies_ms_.push_back(MsBetween(item.submitted, end));
        break;
    }
    // Idle: catch up on pose corrections, within the time share (still busy: Flush() waits).
    if (queue_.empty() && mapper_options_.max_rebuild_share > 0 && !error_) {
      lock.unlock();
      const double rebuild_ms = MaybeRebuild();
      lock.lock();
      if (rebuild_ms >= 0) {
        ++stats_.num_background_rebuilds;
        stats_.background_rebuild_ms += rebuild_ms;
      }
    }
    busy_ = false;
    changed_.notify_all();
  }
}

}  // namespace dygslam
