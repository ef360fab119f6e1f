#include "core/base/stop_signal.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <thread>

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

// A parent that blocked the run's signals (the mask survives exec) does not keep them from the
// run: a blocked SIGCONT would continue a stopped process without its pause ever being counted.
TEST(StopSignals, RunSignalsBlockedByTheParentAreUnblocked) {
  std::thread([] {
    const unsigned before = TimesContinued();  // the counter's handler installed
    sigset_t blocked, now;
    sigemptyset(&blocked);
    for (const int sig : {SIGINT, SIGTERM, SIGHUP, SIGCONT, SIGUSR1}) sigaddset(&blocked, sig);
    ASSERT_EQ(pthread_sigmask(SIG_BLOCK, &blocked, nullptr), 0);
    UnblockRunSignals();
    ASSERT_EQ(pthread_sigmask(SIG_BLOCK, nullptr, &now), 0);
    for (const int sig : {SIGINT, SIGTERM, SIGHUP, SIGCONT})
      EXPECT_EQ(sigismember(&now, sig), 0) << "signal " << sig << " still blocked";
    EXPECT_EQ(sigismember(&now, SIGUSR1), 1) << "signals the run does not act on stay as given";
    raise(SIGCONT);
    EXPECT_EQ(TimesContinued(), before + 1) << "a continue reaches the counter";
  }).join();
}

TEST(StopFlag, RequestWakesAWaiterAndStays) {
  StopFlag flag;
  EXPECT_FALSE(flag.requested());
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_FALSE(flag.WaitFor(std::chrono::milliseconds(30)));  // times out unset
  EXPECT_GE(std::chrono::steady_clock::now() - t0, std::chrono::milliseconds(30));
  std::thread requester([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    flag.Request();
  });
  EXPECT_TRUE(flag.WaitFor(std::chrono::seconds(60)));  // woken by Request, not the timeout
  requester.join();
  EXPECT_TRUE(flag.requested());
  EXPECT_EQ(flag.signal(), 0);
}

TEST(StopFlag, SignalsSetOnlyAFlagMadeToStopOnThem) {
  ASSERT_FALSE(HandlerInstalled(SIGTERM));
  {
    StopFlag on_signals(StopFlag::Signals::kStop);  // installs the handlers while it lives
    StopFlag plain;
    EXPECT_TRUE(HandlerInstalled(SIGTERM));
    EXPECT_FALSE(on_signals.requested());
    std::thread raiser([] {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      raise(SIGTERM);
    });
    EXPECT_TRUE(on_signals.WaitFor(std::chrono::seconds(60)));  // seen within the poll period
    raiser.join();
    EXPECT_EQ(on_signals.signal(), SIGTERM);
    EXPECT_TRUE(on_signals.requested());
    EXPECT_FALSE(plain.requested());
    EXPECT_EQ(plain.signal(), 0);
  }
  EXPECT_FALSE(HandlerInstalled(SIGTERM));
}

}  // namespace
}  // namespace dygslam
