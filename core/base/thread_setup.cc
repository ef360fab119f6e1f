#include "core/base/thread_setup.h"

#include <pthread.h>

#include <optional>

#if defined(__linux__)
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cerrno>
#endif

namespace dygslam {

namespace {
constexpr int kBackgroundNiceness = 10;

#if defined(__linux__)
// On Linux the nice value belongs to the thread (its kernel task id), not the process.
id_t CurrentTaskId() { return static_cast<id_t>(syscall(SYS_gettid)); }

// The calling thread's nice value, or nothing when the system does not say.
std::optional<int> ReadNiceness() {
  errno = 0;
  const int now = getpriority(PRIO_PROCESS, CurrentTaskId());
  if (now == -1 && errno != 0) return std::nullopt;
  return now;
}
#endif
}  // namespace

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
  const std::optional<int> now = ReadNiceness();
  if (!now) return false;
  if (*now >= kBackgroundNiceness) return true;
  return setpriority(PRIO_PROCESS, CurrentTaskId(), kBackgroundNiceness) == 0;
#else
  return false;
#endif
}

int CurrentThreadNiceness() {
#if defined(__linux__)
  return ReadNiceness().value_or(0);
#else
  return 0;
#endif
}

}  // namespace dygslam
