#include "core/base/child_process.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <stdexcept>

#include "core/base/stop_signal.h"

extern char** environ;

namespace dygslam {

pid_t StartChildProcess(const ChildProcessOptions& options) {
  if (options.argv.empty()) throw std::runtime_error("StartChildProcess: no program");
  std::vector<std::string> argv = options.argv;
  std::vector<char*> cargv;
  for (std::string& s : argv) cargv.push_back(s.data());
  cargv.push_back(nullptr);
  std::vector<std::string> env;
  for (char** e = environ; *e != nullptr; ++e) {
    bool replaced = false;
    for (const auto& [name, value] : options.set_env)
      replaced = replaced || std::strncmp(*e, (name + "=").c_str(), name.size() + 1) == 0;
    if (!replaced) env.emplace_back(*e);
  }
  for (const auto& [name, value] : options.set_env) env.push_back(name + "=" + value);
  std::vector<char*> cenv;
  for (std::string& s : env) cenv.push_back(s.data());
  cenv.push_back(nullptr);
  const pid_t parent = getpid();
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error(std::string("fork: ") + std::strerror(errno));
  if (pid == 0) {
    if (options.dies_with_parent) {
      prctl(PR_SET_PDEATHSIG, SIGKILL);
      if (getppid() != parent) std::_Exit(127);  // the parent died before the line above
    }
    for (const int fd : options.keep_fds) fcntl(fd, F_SETFD, 0);
    execve(cargv[0], cargv.data(), cenv.data());
    std::_Exit(127);
  }
  return pid;
}

ChildExit WaitForChildProcess(pid_t pid, bool forward_stop_signals) {
  int status = 0;
  struct rusage usage {};
  bool forwarded = false;
  for (;;) {
    const int sig = forward_stop_signals ? ScopedStopSignals::Received() : 0;
    if (sig != 0 && !forwarded) {
      ::kill(pid, sig);
      forwarded = true;
    }
    if (wait4(pid, &status, 0, &usage) >= 0) break;
    if (errno != EINTR) throw std::runtime_error(std::string("wait4: ") + std::strerror(errno));
  }
  ChildExit exit;
  exit.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  exit.peak_rss_mib = usage.ru_maxrss / 1024.0;  // Linux: kilobytes
  return exit;
}

std::string FindProgram(const std::string& name) {
  if (name.empty() || name.find('/') != std::string::npos) return name;
  const char* path = std::getenv("PATH");
  std::string dirs = path != nullptr ? path : "/usr/local/bin:/usr/bin:/bin";
  size_t begin = 0;
  while (begin <= dirs.size()) {
    const size_t end = std::min(dirs.find(':', begin), dirs.size());
    const std::string dir = end > begin ? dirs.substr(begin, end - begin) : ".";
    const std::string candidate = dir + "/" + name;
    if (::access(candidate.c_str(), X_OK) == 0) return candidate;
    begin = end + 1;
  }
  return "";
}

int RunProgram(std::vector<std::string> argv) {
  if (argv.empty()) return 127;
  argv[0] = FindProgram(argv[0]);
  if (argv[0].empty()) return 127;
  ChildProcessOptions options;
  options.argv = std::move(argv);
  try {
    return WaitForChildProcess(StartChildProcess(options), /*forward_stop_signals=*/true).exit_code;
  } catch (const std::runtime_error&) {
    return 127;
  }
}

std::string ShellQuote(const std::string& s) {
  if (!s.empty() && s.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                        "0123456789-_./:=,+@") == std::string::npos)
    return s;
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

std::string ReadProcessFile(pid_t pid, const std::string& name) {
  const std::string path = "/proc/" + std::to_string(pid) + "/" + name;
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return "";
  std::string text;
  char buffer[4096];
  ssize_t n = 0;
  while ((n = ::read(fd, buffer, sizeof(buffer))) > 0) text.append(buffer, static_cast<size_t>(n));
  ::close(fd);
  return n < 0 ? "" : text;
}

}  // namespace dygslam
