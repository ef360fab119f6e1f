// RepeatedWarning: the first few occurrences are said, every one is counted, also across threads.
#include "core/base/log.h"

#include <gtest/gtest.h>

#include <thread>
#include <vector>

namespace dygslam {
namespace {

TEST(RepeatedWarning, SaysTheFirstFewAndCountsTheRest) {
  RepeatedWarning w(3);
  int said = 0;
  for (int i = 0; i < 5000; ++i) said += w.Say() ? 1 : 0;
  EXPECT_EQ(said, 3);
  EXPECT_EQ(w.count(), 5000u);
  EXPECT_EQ(w.suppressed(), 4997u);
  RepeatedWarning quiet(3);
  EXPECT_TRUE(quiet.Say());
  EXPECT_EQ(quiet.suppressed(), 0u);
}

TEST(RepeatedWarning, ExactlyTheLimitIsSaidFromManyThreads) {
  RepeatedWarning w(5);
  std::atomic<int> said{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&] {
      for (int i = 0; i < 1000; ++i)
        if (w.Say()) ++said;
    });
  }
  for (auto& t : threads) t.join();
  EXPECT_EQ(said.load(), 5);
  EXPECT_EQ(w.count(), 4000u);
}

}  // namespace
}  // namespace dygslam
