#include "core/base/thread_setup.h"

#include <gtest/gtest.h>

#include <thread>

namespace dygslam {
namespace {

TEST(ThreadSetup, ALowerPriorityStaysWithTheThreadThatAskedForIt) {
  const int before = CurrentThreadNiceness();
  int inside = before;
  bool lowered = false;
  std::thread background([&] {
    lowered = LowerCurrentThreadPriority();
    inside = CurrentThreadNiceness();
  });
  background.join();
  ASSERT_TRUE(lowered);
  EXPECT_GE(inside, 10);
  EXPECT_GT(inside, before);
  EXPECT_EQ(CurrentThreadNiceness(), before);  // the rest of the process keeps its priority
}

TEST(ThreadSetup, ANameIsCutToWhatLinuxKeeps) {
  std::string name;
  std::thread named([&] {
    SetCurrentThreadName("map prepare and more");
    name = CurrentThreadName();
  });
  named.join();
  EXPECT_EQ(name, "map prepare and");
}

}  // namespace
}  // namespace dygslam
