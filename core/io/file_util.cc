#include "core/io/file_util.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <random>
#include <set>
#include <sstream>

#include "core/base/echo.h"
#include "core/base/error.h"
#include "core/base/input_file.h"

namespace dygslam {
namespace fs = std::filesystem;

namespace {

// A folder's spelling for the pin registry: "out/run/", "out/run" and "out//run" alike.
// Relative spellings count from the working directory (which a command does not change).
std::string FolderKey(const fs::path& dir) {
  std::error_code ec;
  const fs::path absolute = fs::absolute(dir, ec);
  std::string key = (ec ? dir : absolute).lexically_normal().string();
  while (key.size() > 1 && key.back() == '/') key.pop_back();
  return key;
}

struct PinnedFolders {
  std::mutex mutex;
  std::map<std::string, int> fds;  // by FolderKey, an open descriptor of the folder pinned
};
PinnedFolders& Pins() {
  static PinnedFolders* pins = new PinnedFolders;  // lives as long as the process
  return *pins;
}

bool IsEmptyFolder(const fs::path& dir) {
  std::error_code ec;
  return fs::is_empty(dir, ec) && !ec;
}

// Says once per folder that the output folder `dir` now names something else (`is_link`: a
// link) and that the outputs go to the folder the command started with, now at `moved`. Called
// with the pins' mutex held.
void WarnFolderMovedOnce(const fs::path& dir, bool is_link, const fs::path& moved) {
  static std::set<std::string> said;
  if (!said.insert(FolderKey(dir)).second) return;
  std::fprintf(stderr,
               "warning: the output folder %s was replaced while the command ran (it now %s): the "
               "outputs are written into the folder the command started with, now %s\n",
               EchoValue(dir.string()).c_str(), is_link ? "is a link" : "names another folder",
               EchoValue(moved.string()).c_str());
}

// The folder to write `path`'s file into: `dir`, unless `dir` is pinned and no longer names the
// folder pinned (see PinOutputFolder). Then the pinned folder where it now is (renamed away: the
// outputs go there, said once), or, when the pinned folder was removed, an empty folder made
// again under its name (pinned in its place); anything else there is refused (InputError).
fs::path PinnedFolderFor(const fs::path& dir, const std::string& path) {
  PinnedFolders& pins = Pins();
  std::lock_guard<std::mutex> lock(pins.mutex);
  const auto it = pins.fds.find(FolderKey(dir));
  if (it == pins.fds.end()) return dir;
  struct stat pinned {
  }, now{}, link{};
  if (::fstat(it->second, &pinned) != 0) return dir;
  const bool exists = ::stat(dir.c_str(), &now) == 0;
  if (exists && pinned.st_dev == now.st_dev && pinned.st_ino == now.st_ino) return dir;
  const bool is_link = ::lstat(dir.c_str(), &link) == 0 && S_ISLNK(link.st_mode);
  if (pinned.st_nlink > 0) {
    // Still there under another name: the outputs go where the folder is now.
    std::error_code ec;
    const fs::path moved = fs::read_symlink("/proc/self/fd/" + std::to_string(it->second), ec);
    if (!ec && fs::is_directory(moved, ec)) {
      WarnFolderMovedOnce(dir, is_link, moved);
      return moved;
    }
  }
  // Removed, and made again (empty) under its name: pinned in its place.
  if (exists && !is_link && S_ISDIR(now.st_mode) && IsEmptyFolder(dir)) {
    const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd >= 0) {
      ::close(it->second);
      it->second = fd;
    }
    return dir;
  }
  if (!exists) return dir;  // the caller says that it does not exist
  throw InputError(path, 0,
                   "not written: the output folder " + EchoValue(dir.string()) +
                       " was removed while the command ran and something else put in its place "
                       "(" +
                       (is_link                ? std::string("a link")
                        : S_ISDIR(now.st_mode) ? std::string("a folder with files")
                                               : std::string("a file")) +
                       "); nothing is written into it");
}

}  // namespace

std::string PinnedFolderNow(const std::string& dir) {
  PinnedFolders& pins = Pins();
  std::lock_guard<std::mutex> lock(pins.mutex);
  const auto it = pins.fds.find(FolderKey(dir));
  if (it == pins.fds.end()) return dir;
  struct stat pinned {
  }, now{}, link{};
  if (::fstat(it->second, &pinned) != 0 || pinned.st_nlink == 0) return dir;
  if (::stat(dir.c_str(), &now) == 0 && pinned.st_dev == now.st_dev && pinned.st_ino == now.st_ino)
    return dir;
  std::error_code ec;
  const fs::path moved = fs::read_symlink("/proc/self/fd/" + std::to_string(it->second), ec);
  if (ec) return dir;
  const bool is_link = ::lstat(dir.c_str(), &link) == 0 && S_ISLNK(link.st_mode);
  WarnFolderMovedOnce(dir, is_link, moved);
  return moved.string();
}

void PinOutputFolder(const std::string& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0)
    throw InputError(dir, 0, std::string("cannot open the folder: ") + std::strerror(errno));
  PinnedFolders& pins = Pins();
  std::lock_guard<std::mutex> lock(pins.mutex);
  auto [it, inserted] = pins.fds.emplace(FolderKey(dir), fd);
  if (inserted) return;
  // Pinned already (a command and a component of it in one process): the first pin stands, the
  // folder the command started with, while that folder exists (wherever it is now).
  struct stat pinned {};
  if (::fstat(it->second, &pinned) == 0 && pinned.st_nlink > 0) {
    ::close(fd);
    return;
  }
  ::close(it->second);
  it->second = fd;
}

void PinFolderOfOutput(const std::string& file) {
  const fs::path parent = fs::path(file).parent_path();
  const fs::path dir = parent.empty() ? fs::path(".") : parent;
  std::error_code ec;
  if (fs::is_directory(dir, ec)) PinOutputFolder(dir.string());
}

void WriteFileAtomically(const std::string& path, const std::string& content) {
  const fs::path target(path);
  const fs::path dir = target.parent_path().empty() ? fs::path(".") : target.parent_path();
  const fs::path into = PinnedFolderFor(dir, path);
  if (into != dir) {
    WriteFileAtomically((into / target.filename()).string(), content);
    return;
  }
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    throw InputError(path, 0, "cannot write: directory " + dir.string() + " does not exist");
  }
  // The rename below would replace whatever `path` names: never a device (/dev/full), a FIFO, a
  // socket or a folder.
  const fs::file_status status = fs::status(target, ec);
  if (!ec && fs::exists(status) && !fs::is_regular_file(status)) {
    const char* kind = fs::is_directory(status)        ? "a folder"
                       : fs::is_character_file(status) ? "a character device"
                       : fs::is_block_file(status)     ? "a block device"
                       : fs::is_fifo(status)           ? "a FIFO"
                       : fs::is_socket(status)         ? "a socket"
                                                       : "not a regular file";
    throw InputError(path, 0,
                     std::string("cannot write: it exists and is ") + kind +
                         ", not a regular file (it is left as it is)");
  }
  // The temporary file is made new (O_EXCL, O_NOFOLLOW) under a name no one can plant in advance:
  // a file or a symbolic link already there under that name is never written through.
  static std::atomic<uint64_t> counter{0};
  std::string tmp;
  int fd = -1;
  for (int attempt = 0; fd < 0; ++attempt) {
    const uint64_t salt = std::random_device{}() ^ (counter.fetch_add(1) << 32);
    char suffix[64];
    std::snprintf(suffix, sizeof(suffix), ".tmp.%d.%016llx", static_cast<int>(::getpid()),
                  static_cast<unsigned long long>(salt));
    tmp = path + suffix;
    fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0666);
    if (fd < 0 && (errno != EEXIST || attempt >= 16))
      throw InputError(path, 0, std::string("cannot write: ") + std::strerror(errno));
  }
  size_t written = 0;
  while (written < content.size()) {
    const ssize_t n = ::write(fd, content.data() + written, content.size() - written);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    written += static_cast<size_t>(n);
  }
  const bool flushed = ::fsync(fd) == 0;
  const bool closed = ::close(fd) == 0;
  if (written != content.size() || !flushed || !closed) {
    ::unlink(tmp.c_str());
    throw InputError(path, 0, "cannot write: short write (disk full?)");
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const std::string reason = std::strerror(errno);
    ::unlink(tmp.c_str());
    throw InputError(path, 0, "cannot rename temporary file into place: " + reason);
  }
}

FileVersion FileVersionOf(const std::string& path) {
  FileVersion v;
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return v;
  v.exists = true;
  v.device = static_cast<unsigned long long>(st.st_dev);
  v.inode = static_cast<unsigned long long>(st.st_ino);
  v.mtime_ns = static_cast<long long>(st.st_mtim.tv_sec) * 1000000000LL + st.st_mtim.tv_nsec;
  v.size = static_cast<long long>(st.st_size);
  return v;
}

bool SameFile(const std::string& a, const std::string& b) {
  if (a.empty() || b.empty()) return false;
  std::error_code ec;
  if (fs::exists(a, ec) && fs::exists(b, ec) && fs::equivalent(a, b, ec) && !ec) return true;
  const fs::path ca = fs::weakly_canonical(fs::absolute(a, ec), ec);
  const fs::path cb = fs::weakly_canonical(fs::absolute(b, ec), ec);
  return !ca.empty() && ca.lexically_normal() == cb.lexically_normal();
}

std::string FindOutputClash(const std::vector<NamedPath>& inputs,
                            const std::vector<NamedPath>& outputs) {
  const auto quote = [](const std::string& path) { return "'" + EchoValue(path) + "'"; };
  for (size_t i = 0; i < outputs.size(); ++i) {
    const NamedPath& out = outputs[i];
    for (const NamedPath& in : inputs) {
      if (!SameFile(out.path, in.path)) continue;
      return out.role + " " + quote(out.path) + " is " + in.role + " " + quote(in.path) +
             ", an input: writing it would replace that file; choose another path";
    }
    for (size_t j = 0; j < i; ++j) {
      if (!SameFile(out.path, outputs[j].path)) continue;
      return out.role + " " + quote(out.path) + " is also " + outputs[j].role + " " +
             quote(outputs[j].path) + ", another output of this command: one of them would be " +
             "lost; choose another path";
    }
  }
  return "";
}

std::string FindForeignFileAtOutput(const NamedPath& output, const std::string& signature,
                                    const std::string& kind) {
  struct stat st {};
  if (output.path.empty() || ::stat(output.path.c_str(), &st) != 0 || !S_ISREG(st.st_mode) ||
      st.st_size == 0)
    return "";
  std::ifstream in(output.path, std::ios::binary);
  std::string head(signature.size(), '\0');
  if (in && in.read(head.data(), static_cast<std::streamsize>(head.size())) && head == signature)
    return "";
  return output.role + " '" + EchoValue(output.path) + "' exists and is not " + kind +
         ": it is not replaced; remove it first or choose another path";
}

std::string FindOutputAmongInputs(const std::vector<NamedPath>& inputs,
                                  const std::vector<NamedPath>& outputs) {
  std::error_code ec;
  const auto resolved = [&ec](const std::string& path) {
    return fs::weakly_canonical(fs::absolute(path, ec), ec).lexically_normal().string();
  };
  const auto identity = [](const std::string& path) -> std::pair<uintmax_t, uintmax_t> {
    struct stat st;
    if (::stat(path.c_str(), &st) != 0) return {0, 0};
    return {static_cast<uintmax_t>(st.st_dev), static_cast<uintmax_t>(st.st_ino)};
  };
  std::map<std::string, const NamedPath*> by_path;
  std::map<std::pair<uintmax_t, uintmax_t>, const NamedPath*> by_inode;
  for (const NamedPath& in : inputs) {
    if (in.path.empty()) continue;
    by_path.emplace(resolved(in.path), &in);
    if (const auto id = identity(in.path); id.second != 0) by_inode.emplace(id, &in);
  }
  for (const NamedPath& out : outputs) {
    if (out.path.empty()) continue;
    const NamedPath* in = nullptr;
    if (const auto it = by_path.find(resolved(out.path)); it != by_path.end()) in = it->second;
    const auto id = identity(out.path);
    if (in == nullptr && id.second != 0) {
      if (const auto it = by_inode.find(id); it != by_inode.end()) in = it->second;
    }
    if (in != nullptr)
      return out.role + " '" + EchoValue(out.path) + "' is " + in->role + " '" +
             EchoValue(in->path) + "', an input: writing it would replace that file; choose " +
             "another path";
  }
  return "";
}

std::string Abbreviate(const std::string& text, size_t max_chars) {
  return EchoValue(text, max_chars);
}

std::vector<TextLine> ReadDataLines(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError(path, 0, "file not found");
  if (fs::is_directory(path, ec)) throw InputError(path, 0, "is a directory, expected a file");
  // A pipe is fine (`<(...)`); a device (/dev/zero) would be read forever.
  if (!fs::is_regular_file(path, ec) && !fs::is_fifo(path, ec))
    throw InputError(path, 0, "not a regular file (a device or a socket)");
  // A pipe is read with a bound on the wait for its writer (a FIFO nobody writes into would block
  // forever) and on its size; a regular file is streamed.
  std::istringstream piped;
  std::ifstream file;
  const bool pipe = fs::is_fifo(path, ec);
  if (pipe) {
    constexpr size_t kMaxPipeBytes = size_t{1} << 30;
    std::string content = ReadPipeBounded(path, kMaxPipeBytes, "list file");
    if (content.size() > kMaxPipeBytes) throw InputError(path, 0, "pipe sent more than 1 GiB");
    piped.str(std::move(content));
  } else {
    file.open(path);
    if (!file) throw InputError(path, 0, "cannot open file for reading");
  }
  std::istream& in = pipe ? static_cast<std::istream&>(piped) : file;
  std::vector<TextLine> lines;
  std::string raw;
  int number = 0;
  while (std::getline(in, raw)) {
    ++number;
    if (number == 1 && raw.compare(0, 3, "\xEF\xBB\xBF") == 0) raw.erase(0, 3);  // UTF-8 BOM
    if (!raw.empty() && raw.back() == '\r') raw.pop_back();
    size_t first = raw.find_first_not_of(" \t");
    if (first == std::string::npos || raw[first] == '#') continue;
    for (char& c : raw) {
      if (c == ',' || c == '\t') c = ' ';
    }
    TextLine line;
    line.line_number = number;
    std::istringstream tokens(raw);
    std::string token;
    while (tokens >> token) line.tokens.push_back(token);
    lines.push_back(std::move(line));
  }
  if (in.bad()) throw InputError(path, number, "read error");
  return lines;
}

}  // namespace dygslam
