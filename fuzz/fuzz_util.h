// Helpers shared by the libFuzzer targets: a per-process scratch directory and file writing.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

#include <unistd.h>

namespace dygslam::fuzz {

// A scratch directory of this process, created once, removed at exit (intentionally leaked so
// the exit handler can still use it).
inline const std::string& ScratchDir() {
  static const std::string* dir = [] {
    auto* path = new std::string("/tmp/dygslam_fuzz_XXXXXX");
    if (mkdtemp(path->data()) == nullptr) std::abort();
    std::atexit([] { std::system(("rm -rf '" + ScratchDir() + "'").c_str()); });
    return path;
  }();
  return *dir;
}

inline void WriteFile(const std::string& path, std::string_view bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

// Splits the input at `separator` bytes into at most `max_parts` parts (the last part keeps the
// rest, separators included).
inline std::vector<std::string_view> Split(const uint8_t* data, size_t size, char separator,
                                           size_t max_parts) {
  std::string_view all(reinterpret_cast<const char*>(data), size);
  std::vector<std::string_view> parts;
  while (parts.size() + 1 < max_parts) {
    const size_t at = all.find(separator);
    if (at == std::string_view::npos) break;
    parts.push_back(all.substr(0, at));
    all.remove_prefix(at + 1);
  }
  parts.push_back(all);
  parts.resize(max_parts);
  return parts;
}

}  // namespace dygslam::fuzz
