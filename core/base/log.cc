#include "core/base/log.h"

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <mutex>

namespace dygslam {
namespace {
LogLevel InitialLevel() {
  const char* env = std::getenv("DYGSLAM_LOG");
  if (env == nullptr) return LogLevel::kInfo;
  const std::string v(env);
  if (v == "debug") return LogLevel::kDebug;
  if (v == "warning") return LogLevel::kWarning;
  if (v == "error") return LogLevel::kError;
  if (v == "silent") return LogLevel::kSilent;
  return LogLevel::kInfo;
}
std::atomic<LogLevel>& Level() {
  static std::atomic<LogLevel> level{InitialLevel()};
  return level;
}
std::mutex& OutputMutex() {
  static std::mutex m;
  return m;
}
}  // namespace

void SetLogLevel(LogLevel level) { Level() = level; }
LogLevel GetLogLevel() { return Level(); }

void LogLine(LogLevel level, const std::string& line) {
  static const char* kNames[] = {"D", "I", "W", "E", "S"};
  std::lock_guard<std::mutex> lock(OutputMutex());
  std::fprintf(stderr, "[%s] %s\n", kNames[static_cast<int>(level)], line.c_str());
}

}  // namespace dygslam
