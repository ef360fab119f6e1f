// Minimal leveled logging to stderr; thread-safe line output.
#pragma once

#include <atomic>
#include <cstddef>
#include <sstream>
#include <string>

namespace dygslam {

enum class LogLevel { kDebug = 0, kInfo = 1, kWarning = 2, kError = 3, kSilent = 4 };

void SetLogLevel(LogLevel level);
LogLevel GetLogLevel();
void LogLine(LogLevel level, const std::string& line);

namespace internal {
class LogMessage {
 public:
  explicit LogMessage(LogLevel level) : level_(level) {}
  ~LogMessage() { LogLine(level_, stream_.str()); }
  std::ostringstream& stream() { return stream_; }

 private:
  LogLevel level_;
  std::ostringstream stream_;
};
}  // namespace internal

// A warning that a peer or an input can repeat without bound (a hostile participant publishing
// thousands of malformed samples): the first `limit` occurrences are said, the rest are counted
// and said once, as a total, by the owner at the end (suppressed()). Thread-safe.
//   static RepeatedWarning malformed(3);
//   if (malformed.Say()) LOG_WARNING << ...;
class RepeatedWarning {
 public:
  explicit RepeatedWarning(size_t limit = 3) : limit_(limit) {}
  // True for the first `limit` calls.
  bool Say() { return count_.fetch_add(1) < limit_; }
  size_t count() const { return count_.load(); }
  size_t suppressed() const {
    const size_t n = count_.load();
    return n > limit_ ? n - limit_ : 0;
  }

 private:
  const size_t limit_;
  std::atomic<size_t> count_{0};
};

}  // namespace dygslam

#define DYGSLAM_LOG(level)                                     \
  if (::dygslam::LogLevel::level < ::dygslam::GetLogLevel()) { \
  } else                                                       \
    ::dygslam::internal::LogMessage(::dygslam::LogLevel::level).stream()

#define LOG_DEBUG DYGSLAM_LOG(kDebug)
#define LOG_INFO DYGSLAM_LOG(kInfo)
#define LOG_WARNING DYGSLAM_LOG(kWarning)
#define LOG_ERROR DYGSLAM_LOG(kError)
