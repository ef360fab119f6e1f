// Delivery bookkeeping on both ends of a reliable topic, free of DDS so that it is tested alone.
//
// SequenceTracker (reader side): the samples of one writer carry consecutive sequence numbers.
// A sample numbered at or below the last one taken from its writer came twice (a reader that its
// writer lost for a lease period and matched again gets the writer's history again) and is
// dropped; a jump counts the samples that never arrived (they left the writer's bounded history
// while the reader was unreachable).
//
// OrderedSender (writer side): messages go out in order on a thread of their own, so that a
// reader that does not acknowledge (a paused mapper keeps a keep-all history full) never blocks
// the producer. A message the writer refuses is retried until it is accepted (the reader
// acknowledged, or its lease ran out and it was unmatched), never dropped while the sender runs;
// Finish() gives the last ones a bounded time and counts what was not delivered.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <thread>

#include "components/protocol.h"
#include "core/base/thread_setup.h"

namespace dygslam {

class SequenceTracker {
 public:
  // True when the sample is new (use it), false when it came before.
  bool Accept(const WriterGuid& writer, uint64_t sequence) {
    auto [it, first] = last_.emplace(writer, sequence);
    if (first) return true;
    if (sequence <= it->second) {
      ++duplicates_;
      return false;
    }
    missed_ += sequence - it->second - 1;
    it->second = sequence;
    return true;
  }
  uint64_t missed() const { return missed_; }
  uint64_t duplicates() const { return duplicates_; }

 private:
  std::map<WriterGuid, uint64_t> last_;
  uint64_t missed_ = 0, duplicates_ = 0;
};

template <class Message>
class OrderedSender {
 public:
  // `write` returns false when the writer refused the message (it blocked for its
  // max_blocking_time first); `retry_pause` between attempts; at most `max_pending` messages wait
  // (more are counted as not delivered: memory stays bounded when a reader never acknowledges);
  // `on_refused(pending)` once per refusal episode (its first refusal); the sending thread is
  // named `thread_name` (top -H) when given.
  OrderedSender(std::function<bool(const Message&)> write, size_t max_pending,
                std::chrono::milliseconds retry_pause,
                std::function<void(size_t pending)> on_refused = {}, std::string thread_name = "")
      : write_(std::move(write)),
        on_refused_(std::move(on_refused)),
        max_pending_(max_pending),
        retry_pause_(retry_pause),
        thread_name_(std::move(thread_name)),
        thread_([this] { Loop(); }) {}
  ~OrderedSender() { Finish(std::chrono::milliseconds(0)); }
  OrderedSender(const OrderedSender&) = delete;
  OrderedSender& operator=(const OrderedSender&) = delete;

  void Send(Message message) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (finishing_ || pending_.size() >= max_pending_) {
        ++undelivered_;
        return;
      }
      pending_.push_back(std::move(message));
    }
    cv_.notify_all();
  }
  // Sends what is pending within `timeout` and stops; returns the number of messages never
  // delivered (pending at the deadline, or beyond max_pending). Idempotent.
  size_t Finish(std::chrono::milliseconds timeout) {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      if (!finishing_) {
        finishing_ = true;
        deadline_ = std::chrono::steady_clock::now() + timeout;
      }
    }
    cv_.notify_all();
    if (thread_.joinable()) thread_.join();
    std::lock_guard<std::mutex> lock(mutex_);
    undelivered_ += pending_.size();
    pending_.clear();
    return undelivered_;
  }
  size_t refusals() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return refusals_;
  }
  size_t pending() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return pending_.size();
  }

 private:
  void Loop() {
    if (!thread_name_.empty()) SetCurrentThreadName(thread_name_);
    bool refusing = false;
    std::unique_lock<std::mutex> lock(mutex_);
    while (true) {
      cv_.wait(lock, [&] { return finishing_ || !pending_.empty(); });
      if (pending_.empty()) return;  // finishing, everything sent
      if (finishing_ && std::chrono::steady_clock::now() >= deadline_) return;
      Message& front = pending_.front();
      lock.unlock();
      const bool accepted = write_(front);  // may block (the writer's max_blocking_time)
      lock.lock();
      if (accepted) {
        pending_.pop_front();
        refusing = false;
        continue;
      }
      ++refusals_;
      if (!refusing && on_refused_) {
        const size_t pending = pending_.size();
        lock.unlock();
        on_refused_(pending);
        lock.lock();
      }
      refusing = true;
      cv_.wait_for(lock, retry_pause_,
                   [&] { return finishing_ && std::chrono::steady_clock::now() >= deadline_; });
    }
  }

  std::function<bool(const Message&)> write_;
  std::function<void(size_t)> on_refused_;
  const size_t max_pending_;
  const std::chrono::milliseconds retry_pause_;
  const std::string thread_name_;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<Message> pending_;
  bool finishing_ = false;
  std::chrono::steady_clock::time_point deadline_;
  size_t undelivered_ = 0, refusals_ = 0;
  std::thread thread_;  // last: starts once the members above exist
};

}  // namespace dygslam
