// Helpers for tests: shared data lookup and scratch directories.
#pragma once

#include <sys/types.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

namespace dygslam::testing {

// Directory of the shared data (DYGSLAM_DATA_DIR or the default), "" when absent.
std::string DataDir();
// <DataDir()>/<name> if it exists, else "".
std::string DatasetDir(const std::string& name);
// Models directory ("" when absent).
std::string ModelsDir();
// True when tests that need data, models or built tools must fail instead of skipping: in CI
// (CI=true), in `make test` (DYGSLAM_REQUIRE_DATA=1, set by scripts/run_tests.sh).
bool RequireData();
// How to make a missing dataset or model available (appended to skip and failure messages).
inline constexpr const char* kHowToGetData =
    "get it with `scripts/fetch_data.sh bonn_crowd_part` (models: `scripts/fetch_data.sh "
    "yolov3-tiny`, or the project's shared models folder) and set DYGSLAM_DATA_DIR / "
    "DYGSLAM_MODELS_DIR";
// A fresh empty directory under the build tree (or /tmp), unique per call.
std::string MakeTempDir(const std::string& prefix);

// The whole content of file `path` ("" when it cannot be read: a test then fails on what is missing
// in it, with the rest of its message).
std::string ReadAll(const std::string& path);

// The built `dygslam` executable ($DYGSLAM_BINARY_DIR/apps/dygslam).
std::string DygslamBinary();
// What a finished child process left: its exit code (128 + signal when killed) and output.
struct ProcessResult {
  int code = -1;
  std::string out, err;
};
// Runs `dygslam args...` to completion, stdout and stderr captured through files in `scratch_dir`.
ProcessResult RunDygslam(const std::vector<std::string>& args, const std::string& scratch_dir);
// Starts `dygslam ARGS` with stdout / stderr redirected to the files; returns its pid (the caller
// waits for it).
pid_t SpawnDygslam(const std::vector<std::string>& args, const std::string& out,
                   const std::string& err);
// Waits up to `timeout_s` for child `pid` to exit; returns its exit code (128 + signal when
// killed). A child still running at the deadline is a hang: its threads' stacks (gdb, when
// installed) are appended to `*diagnostics`, it is killed and reaped, and -1 is returned, so a test
// reports which process hung and where instead of running into ctest's timeout with no output.
int WaitForExit(pid_t pid, double timeout_s, std::string* diagnostics);
// Whether some process holds an exclusive flock on `path` (a file or a folder), read from
// /proc/locks, which takes no lock of its own: a test can wait for a command to hold its output
// folder without racing it for the lock.
bool ExclusiveFlockHeld(const std::string& path);

}  // namespace dygslam::testing

// Skips the test (GTEST_SKIP) with a clear reason when a dataset is not available, for someone
// running one test by hand without data... except in CI and `make test` (RequireData()), where a
// missing dataset fails the test.
#define DYGSLAM_REQUIRE_DATASET(var, name)                                                     \
  const std::string var = ::dygslam::testing::DatasetDir(name);                                \
  if (var.empty()) {                                                                           \
    if (::dygslam::testing::RequireData())                                                     \
      FAIL() << "dataset " << name << " missing (required in CI / make test); "                \
             << ::dygslam::testing::kHowToGetData;                                             \
    GTEST_SKIP() << "dataset " << name << " not found; " << ::dygslam::testing::kHowToGetData; \
  }

// The same for the detector models folder.
#define DYGSLAM_REQUIRE_MODELS(var)                                                   \
  const std::string var = ::dygslam::testing::ModelsDir();                            \
  if (var.empty()) {                                                                  \
    if (::dygslam::testing::RequireData())                                            \
      FAIL() << "models folder missing (required in CI / make test); "                \
             << ::dygslam::testing::kHowToGetData;                                    \
    GTEST_SKIP() << "models folder not found; " << ::dygslam::testing::kHowToGetData; \
  }

// The same for a built tool (e.g. the `dygslam` binary) that a test runs.
#define DYGSLAM_REQUIRE_FILE(path, what)                                             \
  if (!std::filesystem::exists(path)) {                                              \
    if (::dygslam::testing::RequireData()) FAIL() << what << " missing: " << (path); \
    GTEST_SKIP() << what << " not found: " << (path);                                \
  }
