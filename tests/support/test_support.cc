#include "tests/support/test_support.h"

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <random>

#include <unistd.h>

#include "core/base/paths.h"

namespace dygslam::testing {
namespace fs = std::filesystem;

namespace {
// Test processes get the build-time locations unless the environment overrides them.
const bool kEnvironmentReady = [] {
  ::setenv("DYGSLAM_SOURCE_DIR", DYGSLAM_BAKED_SOURCE_DIR, 0);
  ::setenv("DYGSLAM_BINARY_DIR", DYGSLAM_BAKED_BINARY_DIR, 0);
  ::setenv("DYGSLAM_DEFAULT_DATA_DIR", DYGSLAM_BAKED_DATA_DIR, 0);
  ::setenv("DYGSLAM_DEFAULT_MODELS_DIR", DYGSLAM_BAKED_MODELS_DIR, 0);
  return true;
}();
}  // namespace

std::string DataDir() { return ::dygslam::DataDir(); }

std::string DatasetDir(const std::string& name) {
  const std::string root = DataDir();
  if (root.empty()) return "";
  const fs::path p = fs::path(root) / name;
  std::error_code ec;
  return fs::is_directory(p, ec) ? p.string() : "";
}

std::string ModelsDir() { return ::dygslam::ModelsDir(); }

bool RequireData() {
  auto set = [](const char* name) {
    const char* v = std::getenv(name);
    if (v == nullptr) return false;
    const std::string s(v);
    return !s.empty() && s != "0" && s != "false";
  };
  return set("DYGSLAM_REQUIRE_DATA") || set("CI");
}

std::string MakeTempDir(const std::string& prefix) {
  static std::atomic<int> counter{0};
  const char* bin = std::getenv("DYGSLAM_BINARY_DIR");
  fs::path root = bin ? fs::path(bin) / "test_tmp" : fs::temp_directory_path() / "dygslam_test_tmp";
  fs::path dir = root / (prefix + "_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir.string();
}

}  // namespace dygslam::testing
