// Process-wide SIGINT / SIGTERM -> "stop requested" flag, shared by every long-running command
// (dygslam run in all modes, component, bridge) so that a signal arriving at any moment, even
// before the run has set itself up, is seen and ends the run cleanly with its outputs written.
//
//   int main() { ScopedStopSignals early; ... }      // first thing: signals are caught from here
//   on ScopedStopSignals inner;                         // nested scopes share the flag (not reset)
//   while (!ScopedStopSignals::Received()) ...
//
// The outermost scope installs the handlers (saving the previous ones) and clears the flag; it
// restores the previous handlers when it ends. Nested scopes only add a reference.
#pragma once

#include <sys/types.h>

namespace dygslam {

// True when /proc/PID/status lists `sig` among the signals process PID catches (SigCgt): its
// handler is installed, so the signal will not end it by the default action. Linux only.
bool ProcessCatchesSignal(pid_t pid, int sig);

class ScopedStopSignals {
 public:
  ScopedStopSignals();
  ~ScopedStopSignals();
  ScopedStopSignals(const ScopedStopSignals&) = delete;
  ScopedStopSignals& operator=(const ScopedStopSignals&) = delete;

  // The first SIGINT/SIGTERM received since the outermost scope began (0 if none).
  static int Received();
};

}  // namespace dygslam
