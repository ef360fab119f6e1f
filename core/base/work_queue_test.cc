#include "core/base/work_queue.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <future>
#include <string>
#include <thread>
#include <vector>

namespace dygslam {
namespace {

TEST(WorkQueue, ThreadedProcessesEveryItemInOrderBeforeFinishReturns) {
  std::vector<int> seen;  // worker thread only until Finish returns
  WorkQueue<int> queue([&](int& v) { seen.push_back(v); }, /*threaded=*/true);
  for (int i = 0; i < 500; ++i) ASSERT_TRUE(queue.Push(i));
  queue.Finish();
  ASSERT_EQ(seen.size(), 500u);
  for (int i = 0; i < 500; ++i) EXPECT_EQ(seen[i], i);
  EXPECT_TRUE(queue.Idle());
  EXPECT_FALSE(queue.Push(7));  // refused once finished
  queue.Finish();               // twice is fine
  EXPECT_EQ(seen.size(), 500u);
}

TEST(WorkQueue, TheWorkerThreadCarriesItsNameSoToolsCanTellTheStagesApart) {
  std::string seen;
  WorkQueue<int> queue([&](int&) { seen = CurrentThreadName(); }, /*threaded=*/true,
                       /*capacity=*/0, "a long stage name");
  queue.Push(1);
  queue.Finish();
  EXPECT_EQ(seen, "a long stage na");  // Linux keeps 15 characters
  EXPECT_NE(CurrentThreadName(), seen);
}

TEST(WorkQueue, UnthreadedRunsOnlyInDrainInTheCallersThread) {
  std::vector<std::thread::id> threads;
  WorkQueue<int> queue([&](int&) { threads.push_back(std::this_thread::get_id()); }, false);
  queue.Push(1);
  queue.Push(2);
  EXPECT_EQ(queue.Size(), 2u);
  EXPECT_FALSE(queue.Idle());
  EXPECT_TRUE(threads.empty());
  queue.Drain();
  ASSERT_EQ(threads.size(), 2u);
  EXPECT_EQ(threads[0], std::this_thread::get_id());
  EXPECT_TRUE(queue.Idle());
  queue.Push(3);
  queue.Finish();  // drains what is left
  EXPECT_EQ(threads.size(), 3u);
}

TEST(WorkQueue, IdleOnlyWhenNothingQueuedAndNothingRunning) {
  std::promise<void> release;
  std::shared_future<void> released = release.get_future().share();
  std::atomic<bool> started{false};
  WorkQueue<int> queue(
      [&](int&) {
        started = true;
        released.wait();
      },
      true);
  EXPECT_TRUE(queue.Idle());
  queue.Push(1);
  while (!started) std::this_thread::yield();
  EXPECT_EQ(queue.Size(), 0u);
  EXPECT_FALSE(queue.Idle());  // the item is being processed
  release.set_value();
  queue.Finish();
  EXPECT_TRUE(queue.Idle());
}

TEST(WorkQueue, WaitIdleTimesOutWhileBusyAndReturnsOnceDone) {
  std::promise<void> release;
  std::shared_future<void> released = release.get_future().share();
  std::atomic<bool> started{false};
  WorkQueue<int> queue(
      [&](int&) {
        started = true;
        released.wait();
      },
      true);
  EXPECT_TRUE(queue.WaitIdle(std::chrono::milliseconds(0)));
  queue.Push(1);
  while (!started) std::this_thread::yield();
  EXPECT_FALSE(queue.WaitIdle(std::chrono::milliseconds(20)));  // still processing
  std::thread releaser([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    release.set_value();
  });
  EXPECT_TRUE(queue.WaitIdle(std::chrono::seconds(30)));  // woken when the item is done
  releaser.join();
  queue.Finish();
  WorkQueue<int> unthreaded([](int&) {}, false);
  unthreaded.Push(1);
  EXPECT_FALSE(unthreaded.WaitIdle(std::chrono::milliseconds(1)));  // only Drain() processes
  unthreaded.Drain();
  EXPECT_TRUE(unthreaded.WaitIdle(std::chrono::milliseconds(0)));
}

TEST(WorkQueue, CapacityBoundsTheQueueAndPushWaitsForRoom) {
  std::promise<void> release;
  std::shared_future<void> released = release.get_future().share();
  std::atomic<int> done{0};
  WorkQueue<int> queue(
      [&](int&) {
        released.wait();
        ++done;
      },
      true, /*capacity=*/2);
  std::atomic<int> pushed{0};
  std::thread producer([&] {
    for (int i = 0; i < 6; ++i) {
      queue.Push(i);
      ++pushed;
    }
  });
  // One item in the handler, two queued: the producer stops at the fourth push until released.
  while (pushed < 3) std::this_thread::yield();
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_LE(queue.Size(), 2u);
  EXPECT_LE(pushed.load(), 3);
  release.set_value();
  producer.join();
  queue.Finish();
  EXPECT_EQ(done.load(), 6);
}

}  // namespace
}  // namespace dygslam
