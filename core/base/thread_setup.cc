#include "core/base/thread_setup.h"

#include <pthread.h>

#if defined(__linux__)
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cerrno>
#endif

namespace dygslam {

namespace {
constexpr int kBackgroundNiceness = 10;
}

void SetCurrentThreadName(const std::string& name) {
#if defined(__linux__)
  const std::string cut = name.substr(0, 15);
  pthread_setname_np(pthread_self(), cut.c_str());
#else
  (void)name;
#endif
}

std::string CurrentThreadName() {
#if defined(__linux__)
  char buffer[16] = {};
  if (pthread_getname_np(pthread_self(), buffer, sizeof(buffer)) == 0) return buffer;
#endif
  return "";
}

bool LowerCurrentThreadPriority() {
#if defined(__linux__)
  // On Linux the nice value belongs to the thread (its kernel task id), not the process.
  const auto tid = static_cast<id_t>(syscall(SYS_gettid));
  errno = 0;
  const int now = getpriority(PRIO_PROCESS, tid);
  if (now == -1 && errno != 0) return false;
  if (now >= kBackgroundNiceness) return true;
  return setpriority(PRIO_PROCESS, tid, kBackgroundNiceness) == 0;
#else
  return false;
#endif
}

int CurrentThreadNiceness() {
#if defined(__linux__)
  errno = 0;
  const int now = getpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)));
  return (now == -1 && errno != 0) ? 0 : now;
#else
  return 0;
#endif
}

}  // namespace dygslam
