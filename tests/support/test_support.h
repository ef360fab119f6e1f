// Helpers for tests: shared data lookup and scratch directories.
#pragma once

#include <string>
#include <vector>

namespace dygslam::testing {

// Directory of the shared data (DYGSLAM_DATA_DIR or the default), "" when absent.
std::string DataDir();
// <DataDir()>/<name> if it exists, else "".
std::string DatasetDir(const std::string& name);
// Models directory ("" when absent).
std::string ModelsDir();
// A fresh empty directory under the build tree (or /tmp), unique per call.
std::string MakeTempDir(const std::string& prefix);

// The built `dygslam` executable ($DYGSLAM_BINARY_DIR/apps/dygslam).
std::string DygslamBinary();
// What a finished child process left: its exit code (128 + signal when killed) and output.
struct ProcessResult {
  int code = -1;
  std::string out, err;
};
// Runs `dygslam args...` to completion, stdout and stderr captured through files in `scratch_dir`.
ProcessResult RunDygslam(const std::vector<std::string>& args, const std::string& scratch_dir);

}  // namespace dygslam::testing

// Skips the test (GTEST_SKIP) with a clear reason when a dataset is not available... except in
// CI (DYGSLAM_REQUIRE_DATA=1), where a missing dataset fails the test.
#define DYGSLAM_REQUIRE_DATASET(var, name)                                                   \
  const std::string var = ::dygslam::testing::DatasetDir(name);                              \
  if (var.empty()) {                                                                         \
    if (std::getenv("DYGSLAM_REQUIRE_DATA") != nullptr) FAIL() << "dataset missing: " << name; \
    GTEST_SKIP() << "dataset " << name << " not found (set DYGSLAM_DATA_DIR)";               \
  }
