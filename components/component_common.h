// Pieces shared by the component shells: the stop flag (core/base), the protocol
// (components/protocol.h: component kinds, typed status, writer ownership), a small blocking queue.
// No DDS entities here.
#pragma once

#include <chrono>
#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>

#include "components/protocol.h"
#include "core/base/stop_signal.h"

namespace dygslam {

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
