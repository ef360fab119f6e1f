// The one way this program starts another program: `dygslam run --processes` starts its
// components, `dygslam bench` a worker per run. fork + execve with the environment prepared before
// the fork (the child only execs), optionally tied to the parent's life, with chosen descriptors
// kept open across the exec.
#pragma once

#include <sys/types.h>

#include <string>
#include <utility>
#include <vector>

namespace dygslam {

struct ChildProcessOptions {
  std::vector<std::string> argv;  // argv[0]: the program's path
  // Added to (or replacing, by name) this process's environment.
  std::vector<std::pair<std::string, std::string>> set_env;
  // Killed (SIGKILL) when this process dies, even by SIGKILL: nothing it would write outlives
  // the command that started it.
  bool dies_with_parent = false;
  // Descriptors (made close-on-exec by the caller) the child keeps open across the exec.
  std::vector<int> keep_fds;
};

// Starts the child; returns its pid. Throws std::runtime_error when it cannot be started.
pid_t StartChildProcess(const ChildProcessOptions& options);

struct ChildExit {
  int exit_code = -1;       // its exit code, 128 + signal when a signal ended it
  double peak_rss_mib = 0;  // its peak resident memory
};
// Waits for child `pid`. `forward_stop_signals`: a SIGINT / SIGTERM / SIGHUP this process receives
// meanwhile (ScopedStopSignals) is passed on to the child once, so that it ends cleanly.
ChildExit WaitForChildProcess(pid_t pid, bool forward_stop_signals);

// The path of program `name` found on PATH (as a shell would find it), "" when there is none. A
// name with a slash is returned as it is.
std::string FindProgram(const std::string& name);
// Runs `argv` (argv[0] found with FindProgram) to its end, no shell in between; its exit code
// (128 + signal when a signal ended it), 127 when it cannot be found or started.
int RunProgram(std::vector<std::string> argv);

// The text of /proc/PID/`name` ("cmdline", "stat", "status"), "" when the process is gone: it may
// end between the open and the read, which then fails with ESRCH (an exception when read through
// std::istreambuf_iterator).
std::string ReadProcessFile(pid_t pid, const std::string& name);

// `s` as one POSIX shell word: unchanged when it has only safe characters, else single-quoted
// (for a command line a user may copy, or one given to a shell).
std::string ShellQuote(const std::string& s);

}  // namespace dygslam
