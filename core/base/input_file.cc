#include "core/base/input_file.h"

#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>

#include "core/base/error.h"

namespace dygslam {

std::string ReadPipeBounded(const std::string& path, size_t max_bytes, const std::string& what,
                            double wait_s) {
  // Non-blocking open: succeeds at once on a FIFO even without a writer.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) throw InputError(path, 0, "cannot open " + what + ": " + std::strerror(errno));
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  // A FIFO without a writer polls as nothing (Linux): wait for data or a writer's close.
  const auto deadline =
      std::chrono::steady_clock::now() + std::chrono::duration<double>(std::max(wait_s, 0.0));
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
                          deadline - std::chrono::steady_clock::now())
                          .count();
    if (left <= 0) {
      throw InputError(path, 0,
                       what + " is a pipe (FIFO) with nothing written to it after " +
                           std::to_string(static_cast<int>(wait_s)) +
                           " s: is its writer running? (pipes work, e.g. <(cat FILE))");
    }
    pollfd p{fd, POLLIN, 0};
    const int ready = ::poll(&p, 1, static_cast<int>(std::min<long long>(left, 1000)));
    if (ready < 0 && errno != EINTR)
      throw InputError(path, 0, "cannot read " + what + ": " + std::strerror(errno));
    if (ready > 0 && (p.revents & (POLLIN | POLLHUP | POLLERR)) != 0) break;
  }
  // A writer is there: read to the end, blocking.
  const int flags = ::fcntl(fd, F_GETFL);
  if (flags >= 0) ::fcntl(fd, F_SETFL, flags & ~O_NONBLOCK);
  std::string content;
  char buffer[65536];
  while (content.size() <= max_bytes) {
    const ssize_t n = ::read(fd, buffer, sizeof(buffer));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw InputError(path, 0, "cannot read " + what + ": " + std::strerror(errno));
    if (n == 0) break;
    content.append(buffer, static_cast<size_t>(n));
  }
  if (content.size() > max_bytes + 1) content.resize(max_bytes + 1);
  return content;
}

}  // namespace dygslam
