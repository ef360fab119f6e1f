// Pieces shared by the component shells: a stop signal, stream-status kinds, a small blocking
// queue. No DDS types here.
#pragma once

#include <chrono>
#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>

namespace dygslam {

// Set once (SIGINT/SIGTERM, end of data, test teardown); components poll it or wait on it.
class StopSignal {
 public:
  void Request() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    cv_.notify_all();
  }
  bool requested() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return stop_;
  }
  // Sleeps up to `duration`; returns true if stop was requested.
  template <class Rep, class Period>
  bool WaitFor(std::chrono::duration<Rep, Period> duration) const {
    std::unique_lock<std::mutex> lock(mutex_);
    return cv_.wait_for(lock, duration, [this] { return stop_; });
  }

 private:
  mutable std::mutex mutex_;
  mutable std::condition_variable cv_;
  bool stop_ = false;
};
using StopSignalPtr = std::shared_ptr<StopSignal>;

// msg::StreamStatus::kind values.
// kMapLoaded (slam, issue 15): the SLAM map file it started from; num_frames = its keyframe
// count, header.frame_id = "map <checksum hex> <path>".
enum class StreamEvent : uint8_t {
  kStarted = 0,
  kEndOfStream = 1,
  kComponentDone = 2,
  kMapLoaded = 3
};

// Unbounded FIFO for handing samples from a DDS listener thread to a worker thread.
template <class T>
class BlockingQueue {
 public:
  void Push(T value) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      items_.push_back(std::move(value));
    }
    cv_.notify_all();
  }
  // Waits up to `timeout` for an item.
  template <class Rep, class Period>
  std::optional<T> Pop(std::chrono::duration<Rep, Period> timeout) {
    std::unique_lock<std::mutex> lock(mutex_);
    if (!cv_.wait_for(lock, timeout, [this] { return !items_.empty(); })) return std::nullopt;
    T value = std::move(items_.front());
    items_.pop_front();
    return value;
  }
  size_t size() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return items_.size();
  }

 private:
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<T> items_;
};

}  // namespace dygslam
