#include "mapping/atomic_file.h"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>

#include "core/base/error.h"

namespace dygslam {

void WriteFileAtomically(const std::string& path, const std::string& bytes) {
  if (path.empty()) throw InputError("<empty path>", 0, "cannot write: empty file name");
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) {
      throw InputError(path, 0, std::string("cannot open for writing: ") + std::strerror(errno));
    }
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    out.flush();
    if (!out) {
      std::remove(tmp.c_str());
      throw InputError(path, 0, "write failed");
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const std::string reason = std::strerror(errno);
    std::remove(tmp.c_str());
    throw InputError(path, 0, "cannot rename temporary file into place: " + reason);
  }
}

}  // namespace dygslam
