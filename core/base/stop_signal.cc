#include "core/base/stop_signal.h"

#include <signal.h>

#include <atomic>
#include <csignal>
#include <fstream>
#include <mutex>
#include <string>

namespace dygslam {
namespace {

volatile std::sig_atomic_t g_received = 0;
extern "C" void OnStopSignal(int sig) {
  if (g_received == 0) g_received = sig;
}

std::mutex g_mutex;
int g_depth = 0;
struct sigaction g_old_int {
}, g_old_term{}, g_old_hup{}, g_old_pipe{};

}  // namespace

void UnblockRunSignals() {
  sigset_t set;
  sigemptyset(&set);
  for (const int sig : {SIGINT, SIGTERM, SIGHUP, SIGCONT}) sigaddset(&set, sig);
  pthread_sigmask(SIG_UNBLOCK, &set, nullptr);
}

ScopedStopSignals::ScopedStopSignals() {
  std::lock_guard<std::mutex> lock(g_mutex);
  if (g_depth++ > 0) return;
  UnblockRunSignals();
  g_received = 0;
  struct sigaction sa {};
  sa.sa_handler = OnStopSignal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, &g_old_int);
  sigaction(SIGTERM, &sa, &g_old_term);
  // A closed terminal or ssh connection (SIGHUP) stops like Ctrl-C: outputs are written.
  sigaction(SIGHUP, &sa, &g_old_hup);
  // A closed stdout / stderr reader (`dygslam run ... | head`) must not kill the run before its
  // outputs are written: writes to the pipe fail with EPIPE instead.
  struct sigaction ignore {};
  ignore.sa_handler = SIG_IGN;
  sigemptyset(&ignore.sa_mask);
  sigaction(SIGPIPE, &ignore, &g_old_pipe);
}

ScopedStopSignals::~ScopedStopSignals() {
  std::lock_guard<std::mutex> lock(g_mutex);
  if (--g_depth > 0) return;
  sigaction(SIGINT, &g_old_int, nullptr);
  sigaction(SIGTERM, &g_old_term, nullptr);
  sigaction(SIGHUP, &g_old_hup, nullptr);
  sigaction(SIGPIPE, &g_old_pipe, nullptr);
}

int ScopedStopSignals::Received() { return g_received; }

StopFlag::StopFlag(Signals signals) {
  if (signals == Signals::kStop) signals_.emplace();
}

void StopFlag::Request() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    requested_ = true;
  }
  cv_.notify_all();
}

bool StopFlag::requested() const {
  if (signal() != 0) return true;
  std::lock_guard<std::mutex> lock(mutex_);
  return requested_;
}

int StopFlag::signal() const { return signals_ ? ScopedStopSignals::Received() : 0; }

bool ProcessCatchesSignal(pid_t pid, int sig) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("SigCgt:", 0) != 0) continue;
    try {
      return (std::stoull(line.substr(7), nullptr, 16) >> (sig - 1)) & 1u;
    } catch (const std::exception&) {
      return false;
    }
  }
  return false;
}

namespace {
std::atomic<unsigned> continued_count{0};
void CountContinue(int) { continued_count.fetch_add(1, std::memory_order_relaxed); }
}  // namespace

unsigned TimesContinued() {
  static const bool installed = [] {
    struct sigaction action {};
    action.sa_handler = CountContinue;
    sigemptyset(&action.sa_mask);
    action.sa_flags = SA_RESTART;
    UnblockRunSignals();
    return sigaction(SIGCONT, &action, nullptr) == 0;
  }();
  (void)installed;
  return continued_count.load(std::memory_order_relaxed);
}

}  // namespace dygslam
