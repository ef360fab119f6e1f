#include "core/base/standard_output.h"

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <iostream>

namespace dygslam {

std::string StandardOutputError() {
  std::cout.flush();
  errno = 0;
  const bool flushed = std::fflush(stdout) == 0;
  int error = flushed ? 0 : errno;
  if (flushed && !std::ferror(stdout) && !std::cout.fail()) return "";
  if (error == 0) {
    // An earlier flush failed and its errno is gone: one byte tells the reason (the output is
    // broken already).
    errno = 0;
    if (::write(STDOUT_FILENO, "\n", 1) < 0) error = errno;
  }
  if (error == EPIPE) return "";
  struct stat st {};
  if (error == 0 && ::fstat(STDOUT_FILENO, &st) == 0 && S_ISFIFO(st.st_mode)) return "";
  return error != 0 ? std::strerror(error) : "write error";
}

}  // namespace dygslam
