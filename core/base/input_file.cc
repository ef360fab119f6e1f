#include "core/base/input_file.h"

#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>

#include "core/base/echo.h"
#include "core/base/error.h"
#include "core/base/stop_signal.h"

namespace dygslam {

std::string NotRegularFileReason(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (ec || !fs::exists(st) || fs::is_regular_file(st)) return "";
  const std::string target =
      fs::is_symlink(fs::symlink_status(path, ec))
          ? " (a link to " + EchoValue(fs::read_symlink(path, ec).string()) + ")"
          : "";
  const char* kind = fs::is_directory(st)        ? "a directory"
                     : fs::is_fifo(st)           ? "a FIFO"
                     : fs::is_character_file(st) ? "a character device"
                     : fs::is_block_file(st)     ? "a block device"
                     : fs::is_socket(st)         ? "a socket"
                                                 : "not a file";
  return std::string("not a regular file: ") + kind + target;
}

std::string ReadPipeBounded(const std::string& path, size_t max_bytes, const std::string& what,
                            double wait_s) {
  // Non-blocking open: succeeds at once on a FIFO even without a writer. The fd stays
  // non-blocking: every wait is a poll of at most 100 ms, so the total time is bounded and a stop
  // signal ends it.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) throw InputError(path, 0, "cannot open " + what + ": " + std::strerror(errno));
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  const auto deadline =
      std::chrono::steady_clock::now() + std::chrono::duration<double>(std::max(wait_s, 0.0));
  const std::string seconds = std::to_string(static_cast<int>(wait_s));
  std::string content;
  bool writer_seen = false;  // a FIFO without a writer polls as nothing (Linux) until one opens it
  char buffer[65536];
  while (content.size() <= max_bytes) {
    if (const int sig = ScopedStopSignals::Received(); sig != 0) {
      throw StopSignalError(sig, EchoValue(path) + ": stopped by signal " + std::to_string(sig) +
                                     " while reading the " + what + " (a pipe)");
    }
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
                          deadline - std::chrono::steady_clock::now())
                          .count();
    if (left <= 0) {
      if (!writer_seen) {
        throw InputError(path, 0,
                         what + " is a pipe (FIFO) with nothing written to it after " + seconds +
                             " s: is its writer running? (pipes work, e.g. <(cat FILE))");
      }
      throw InputError(path, 0,
                       what + " is a pipe (FIFO) whose writer did not finish within " + seconds +
                           " s (" + std::to_string(content.size()) +
                           " bytes came, then it stalled): is its writer stuck?");
    }
    pollfd p{fd, POLLIN, 0};
    const int ready = ::poll(&p, 1, static_cast<int>(std::min<long long>(left, 100)));
    if (ready < 0 && errno != EINTR)
      throw InputError(path, 0, "cannot read " + what + ": " + std::strerror(errno));
    if (ready <= 0 || (p.revents & (POLLIN | POLLHUP | POLLERR)) == 0) continue;
    const ssize_t n = ::read(fd, buffer, sizeof(buffer));
    if (n < 0 && (errno == EINTR || errno == EAGAIN)) continue;
    if (n < 0) throw InputError(path, 0, "cannot read " + what + ": " + std::strerror(errno));
    if (n == 0) {
      // POLLHUP without data: the writer closed (the end), or none opened it yet (Linux polls a
      // never-opened FIFO as nothing, so this is the end).
      break;
    }
    writer_seen = true;
    content.append(buffer, static_cast<size_t>(n));
  }
  if (content.size() > max_bytes + 1) content.resize(max_bytes + 1);
  return content;
}

}  // namespace dygslam
