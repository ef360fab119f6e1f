// Process-wide SIGINT / SIGTERM / SIGHUP -> "stop requested" flag (SIGPIPE is ignored while it is
// installed: a closed output pipe gives EPIPE, not death), shared by every long-running command
// (dygslam run in all modes, component, bridge) so that a signal arriving at any moment, even
// before the run has set itself up, is seen and ends the run cleanly with its outputs written.
//
//   int main() { ScopedStopSignals early; ... }      // first thing: signals are caught from here
//   on ScopedStopSignals inner;                         // nested scopes share the flag (not reset)
//   while (!ScopedStopSignals::Received()) ...
//
// The outermost scope installs the handlers (saving the previous ones) and clears the flag; it
// restores the previous handlers when it ends. Nested scopes only add a reference.
//
// StopFlag is the one stop flag the loops and components share: Request() sets it, and one made
// with StopFlag::Signals::kStop is also set by SIGINT / SIGTERM.
#pragma once

#include <sys/types.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>

namespace dygslam {

// True when /proc/PID/status lists `sig` among the signals process PID catches (SigCgt): its
// handler is installed, so the signal will not end it by the default action. Linux only.
bool ProcessCatchesSignal(pid_t pid, int sig);

// How many times this process was continued after a stop (SIGSTOP, Ctrl-Z): a SIGCONT handler,
// installed on the first call, counts them. A loop paced by the clock (a replay at the camera's
// rate) tells its own pause from a slow consumer by it.
unsigned TimesContinued();

// Unblocks, in the calling thread, the signals a run acts on (SIGINT, SIGTERM, SIGHUP, SIGCONT).
// The signal mask is inherited across fork and exec: a parent that starts dygslam with them
// blocked (a supervisor, a test harness) would otherwise leave a stop request pending forever
// and a pause unseen (the process continues, its SIGCONT handler never runs). Threads started
// afterwards inherit the unblocked mask; call it first in main().
void UnblockRunSignals();

// A stop signal (SIGINT / SIGTERM / SIGHUP) ended a wait that has nothing to save, e.g. the read
// of a settings pipe before any work: the command ends at once with exit code 128 + signal().
class StopSignalError : public std::runtime_error {
 public:
  StopSignalError(int sig, const std::string& what) : std::runtime_error(what), signal_(sig) {}
  int signal() const { return signal_; }
  int exit_code() const { return 128 + signal_; }

 private:
  int signal_;
};

class ScopedStopSignals {
 public:
  ScopedStopSignals();
  ~ScopedStopSignals();
  ScopedStopSignals(const ScopedStopSignals&) = delete;
  ScopedStopSignals& operator=(const ScopedStopSignals&) = delete;

  // The first SIGINT/SIGTERM received since the outermost scope began (0 if none).
  static int Received();
};

// The one stop flag of a long-running loop or component: set by Request() (end of data, a failed
// peer, a test's teardown) and, when made with StopFlag::Signals::kStop, by SIGINT / SIGTERM
// (it holds a ScopedStopSignals, so the handlers are installed while it lives). Loops poll
// requested() or sleep in WaitFor(), which wakes on Request() at once and on a signal within
// kSignalPollPeriod. Thread-safe; share it as a StopFlagPtr.
class StopFlag {
 public:
  enum class Signals { kIgnore, kStop };
  static constexpr std::chrono::milliseconds kSignalPollPeriod{20};

  explicit StopFlag(Signals signals = Signals::kIgnore);
  StopFlag(const StopFlag&) = delete;
  StopFlag& operator=(const StopFlag&) = delete;

  void Request();
  // Request() was called, or (Signals::kStop) a SIGINT / SIGTERM was received.
  bool requested() const;
  // The signal that stopped it (Signals::kStop), 0 if none.
  int signal() const;
  // Sleeps up to `duration`; returns true if stop was requested.
  template <class Rep, class Period>
  bool WaitFor(std::chrono::duration<Rep, Period> duration) const {
    const auto deadline = std::chrono::steady_clock::now() + duration;
    std::unique_lock<std::mutex> lock(mutex_);
    while (true) {
      if (requested_ || signal() != 0) return true;
      const auto now = std::chrono::steady_clock::now();
      if (now >= deadline) return false;
      const auto slice = signals_ ? std::min<std::chrono::steady_clock::duration>(deadline - now,
                                                                                  kSignalPollPeriod)
                                  : deadline - now;
      cv_.wait_for(lock, slice);
    }
  }

 private:
  std::optional<ScopedStopSignals> signals_;
  mutable std::mutex mutex_;
  mutable std::condition_variable cv_;
  bool requested_ = false;
};
using StopFlagPtr = std::shared_ptr<StopFlag>;

}  // namespace dygslam
