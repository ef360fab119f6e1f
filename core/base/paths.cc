#include "core/base/paths.h"

#include <cstdlib>
#include <filesystem>

namespace dygslam {
namespace fs = std::filesystem;
namespace {
std::string FirstExisting(std::initializer_list<const char*> env_names,
                          std::initializer_list<fs::path> candidates) {
  for (const char* name : env_names) {
    const char* v = std::getenv(name);
    if (v != nullptr && *v != '\0') return v;
  }
  for (const fs::path& p : candidates) {
    std::error_code ec;
    if (!p.empty() && fs::is_directory(p, ec)) return fs::absolute(p).lexically_normal().string();
  }
  return "";
}
fs::path SourceRelative(const char* rel) {
  const char* src = std::getenv("DYGSLAM_SOURCE_DIR");
  if (src == nullptr) return {};
  return fs::path(src) / rel;
}
}  // namespace

std::string DataDir() {
  const char* def = std::getenv("DYGSLAM_DEFAULT_DATA_DIR");
  return FirstExisting({"DYGSLAM_DATA_DIR"},
                       {def ? fs::path(def) : fs::path(), SourceRelative("../shared/data"),
                        fs::path("../shared/data"), fs::path("data")});
}

std::string ModelsDir() {
  const char* def = std::getenv("DYGSLAM_DEFAULT_MODELS_DIR");
  const std::string data = DataDir();
  return FirstExisting({"DYGSLAM_MODELS_DIR"},
                       {def ? fs::path(def) : fs::path(),
                        data.empty() ? fs::path() : fs::path(data) / "../models",
                        SourceRelative("../shared/models"), fs::path("../shared/models"),
                        fs::path("models")});
}

}  // namespace dygslam
