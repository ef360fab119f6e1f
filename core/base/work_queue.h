// A first-in first-out queue of work items served by one worker thread (or, unthreaded, by the
// caller), with an end: local mapping and loop closing each own one.
//
//   WorkQueue<Job> queue([this](Job& job) { Process(job); }, /*threaded=*/true);
//   queue.Push(job);   // false once the queue is finishing (the job is dropped)
//   queue.Finish();    // waits until every pushed job is done, then ends the worker
//
// Unthreaded (deterministic runs), Push only queues and Drain() processes the queue in the
// caller's thread; Finish() drains what is left. `capacity` bounds the queue: Push waits while it
// is full (0 = unbounded). The handler runs without the queue's lock held, so it may Push.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <utility>

#include "core/base/thread_setup.h"

namespace dygslam {

template <typename T>
class WorkQueue {
 public:
  using Handler = std::function<void(T&)>;

  // `name` names the worker thread (SetCurrentThreadName) when there is one.
  WorkQueue(Handler handler, bool threaded, size_t capacity = 0, std::string name = "")
      : handler_(std::move(handler)), threaded_(threaded), capacity_(capacity) {
    if (threaded_) {
      worker_ = std::thread([this, name = std::move(name)] {
        if (!name.empty()) SetCurrentThreadName(name);
        Serve();
      });
    }
  }
  ~WorkQueue() { Finish(); }
  WorkQueue(const WorkQueue&) = delete;
  WorkQueue& operator=(const WorkQueue&) = delete;

  bool Push(T item) {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      if (capacity_ > 0 && threaded_)
        changed_.wait(lock, [this] { return finishing_ || queue_.size() < capacity_; });
      if (finishing_) return false;
      queue_.push_back(std::move(item));
    }
    changed_.notify_all();
    return true;
  }

  // Processes every queued item in the caller's thread (unthreaded queues; no-op when threaded).
  void Drain() {
    if (threaded_) return;
    while (true) {
      T item;
      {
        std::lock_guard<std::mutex> lock(mutex_);
        if (queue_.empty()) return;
        item = std::move(queue_.front());
        queue_.pop_front();
        busy_ = true;
      }
      handler_(item);
      std::lock_guard<std::mutex> lock(mutex_);
      busy_ = false;
    }
  }

  // Waits until the queue is empty and no item is being processed, then ends the worker. Later
  // pushes are refused. Safe to call more than once.
  void Finish() {
    if (!threaded_) {
      Drain();
      std::lock_guard<std::mutex> lock(mutex_);
      finishing_ = true;
      return;
    }
    {
      std::unique_lock<std::mutex> lock(mutex_);
      changed_.wait(lock, [this] { return finishing_ || (queue_.empty() && !busy_); });
      finishing_ = true;
    }
    changed_.notify_all();
    if (worker_.joinable()) worker_.join();
  }

  // Nothing queued and nothing being processed.
  bool Idle() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return queue_.empty() && !busy_;
  }
  // Waits up to `timeout` until Idle() (unthreaded: Idle() at once); true when idle.
  template <typename Rep, typename Period>
  bool WaitIdle(std::chrono::duration<Rep, Period> timeout) {
    std::unique_lock<std::mutex> lock(mutex_);
    if (!threaded_) return queue_.empty() && !busy_;
    return changed_.wait_for(lock, timeout,
                             [this] { return finishing_ || (queue_.empty() && !busy_); });
  }
  size_t Size() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return queue_.size();
  }

 private:
  void Serve() {
    while (true) {
      T item;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        changed_.wait(lock, [this] { return finishing_ || !queue_.empty(); });
        if (queue_.empty()) return;  // finishing
        item = std::move(queue_.front());
        queue_.pop_front();
        busy_ = true;
      }
      changed_.notify_all();  // room for a waiting Push
      handler_(item);
      {
        std::lock_guard<std::mutex> lock(mutex_);
        busy_ = false;
      }
      changed_.notify_all();
    }
  }

  Handler handler_;
  const bool threaded_;
  const size_t capacity_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<T> queue_;
  bool busy_ = false;
  bool finishing_ = false;
  std::thread worker_;  // last: starts once everything above exists
};

}  // namespace dygslam
