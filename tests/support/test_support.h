// Helpers for tests: shared data lookup and scratch directories.
#pragma once

#include <string>

namespace dygslam::testing {

// Directory of the shared data (DYGSLAM_DATA_DIR or the default), "" when absent.
std::string DataDir();
// <DataDir()>/<name> if it exists, else "".
std::string DatasetDir(const std::string& name);
// Models directory ("" when absent).
std::string ModelsDir();
// A fresh empty directory under the build tree (or /tmp), unique per call.
std::string MakeTempDir(const std::string& prefix);

}  // namespace dygslam::testing

// Skips the test (GTEST_SKIP) with a clear reason when a dataset is not available... except in
// CI (DYGSLAM_REQUIRE_DATA=1), where a missing dataset fails the test.
#define DYGSLAM_REQUIRE_DATASET(var, name)                                                   \
  const std::string var = ::dygslam::testing::DatasetDir(name);                              \
  if (var.empty()) {                                                                         \
    if (std::getenv("DYGSLAM_REQUIRE_DATA") != nullptr) FAIL() << "dataset missing: " << name; \
    GTEST_SKIP() << "dataset " << name << " not found (set DYGSLAM_DATA_DIR)";               \
  }
