#include "core/base/stop_signal.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

namespace dygslam {
namespace {

bool HandlerInstalled(int sig) {
  struct sigaction current {};
  sigaction(sig, nullptr, &current);
  return current.sa_handler != SIG_DFL && current.sa_handler != SIG_IGN;
}

TEST(StopSignals, NestedScopesShareTheFlagAndTheOutermostRestoresHandlers) {
  ASSERT_FALSE(HandlerInstalled(SIGTERM));
  EXPECT_FALSE(ProcessCatchesSignal(getpid(), SIGTERM));
  {
    ScopedStopSignals outer;
    EXPECT_TRUE(ProcessCatchesSignal(getpid(), SIGTERM));  // as /proc shows it to other processes
    EXPECT_TRUE(ProcessCatchesSignal(getpid(), SIGINT));
    EXPECT_TRUE(HandlerInstalled(SIGINT));
    EXPECT_TRUE(HandlerInstalled(SIGTERM));
    EXPECT_EQ(ScopedStopSignals::Received(), 0);
    raise(SIGTERM);  // early: before any inner scope exists
    EXPECT_EQ(ScopedStopSignals::Received(), SIGTERM);
    {
      ScopedStopSignals inner;  // does not clear what the outer scope caught
      EXPECT_EQ(ScopedStopSignals::Received(), SIGTERM);
      raise(SIGINT);  // the first signal is kept
      EXPECT_EQ(ScopedStopSignals::Received(), SIGTERM);
    }
    EXPECT_TRUE(HandlerInstalled(SIGTERM)) << "inner scope must not restore the handlers";
  }
  EXPECT_FALSE(HandlerInstalled(SIGTERM));
  ScopedStopSignals fresh;  // a new outermost scope starts clear
  EXPECT_EQ(ScopedStopSignals::Received(), 0);
}

}  // namespace
}  // namespace dygslam
