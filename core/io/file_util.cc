#include "core/io/file_util.h"

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "core/base/echo.h"
#include "core/base/error.h"
#include "core/base/input_file.h"

namespace dygslam {
namespace fs = std::filesystem;

void WriteFileAtomically(const std::string& path, const std::string& content) {
  const fs::path target(path);
  const fs::path dir = target.parent_path().empty() ? fs::path(".") : target.parent_path();
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
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  FILE* f = std::fopen(tmp.c_str(), "wb");
  if (f == nullptr) {
    throw InputError(path, 0, std::string("cannot write: ") + std::strerror(errno));
  }
  const size_t written = std::fwrite(content.data(), 1, content.size(), f);
  const bool flushed = std::fflush(f) == 0 && ::fsync(::fileno(f)) == 0;
  const bool closed = std::fclose(f) == 0;
  if (written != content.size() || !flushed || !closed) {
    std::remove(tmp.c_str());
    throw InputError(path, 0, "cannot write: short write (disk full?)");
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const std::string reason = std::strerror(errno);
    std::remove(tmp.c_str());
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
