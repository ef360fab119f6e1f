// Minimal leveled logging to stderr; thread-safe line output.
#pragma once

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

}  // namespace dygslam

#define DYGSLAM_LOG(level)                                                 \
  if (::dygslam::LogLevel::level < ::dygslam::GetLogLevel()) {             \
  } else                                                                   \
    ::dygslam::internal::LogMessage(::dygslam::LogLevel::level).stream()

#define LOG_DEBUG DYGSLAM_LOG(kDebug)
#define LOG_INFO DYGSLAM_LOG(kInfo)
#define LOG_WARNING DYGSLAM_LOG(kWarning)
#define LOG_ERROR DYGSLAM_LOG(kError)
