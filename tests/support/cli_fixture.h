// The fixture of the command-line tests of tests/reliability/ (cli_*, datasets_*, images_*,
// signals_*, map_files_*, dds_peers_*): runs the dygslam binary in a scratch folder, checks its
// error messages and exit codes, and makes small datasets from the first frames of a real one.
// Header only: its users link dygslam_io.
#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "core/io/dataset.h"
#include "tests/support/test_support.h"

namespace dygslam::testing {

inline bool Contains(const std::string& text, const std::string& needle) {
  return text.find(needle) != std::string::npos;
}

// Waits until `file` (a spawned run's stderr) contains `needle`, at most `timeout`: an event, not
// a time, since a loaded machine starts slowly. Whether it does.
inline bool WaitForText(const std::string& file, const std::string& needle,
                        std::chrono::seconds timeout = std::chrono::seconds(60)) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!Contains(ReadAll(file), needle)) {
    if (std::chrono::steady_clock::now() >= deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return true;
}

class CliFixture : public ::testing::Test {
 protected:
  // scratch: the prefix of the test's temporary folder (dir_).
  explicit CliFixture(std::string scratch) : scratch_(std::move(scratch)) {}

  void SetUp() override {
    DYGSLAM_REQUIRE_FILE(DygslamBinary(), "dygslam binary");
    dir_ = MakeTempDir(scratch_);
  }

  // The settings file of bonn_crowd_part in the source tree.
  static std::string Config() { return std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/bonn.yaml"; }

  ProcessResult Run(const std::vector<std::string>& args) { return RunDygslam(args, dir_); }

  // Runs with a deadline: a hang is a failure with the stacks, not a test stuck until ctest's
  // timeout.
  ProcessResult RunWithin(const std::vector<std::string>& args, double seconds) {
    const std::string out = dir_ + "/within.out", err = dir_ + "/within.err";
    const pid_t pid = SpawnDygslam(args, out, err);
    std::string diagnostics;
    ProcessResult r;
    r.code = WaitForExit(pid, seconds, &diagnostics);
    r.out = ReadAll(out);
    r.err = ReadAll(err) + diagnostics;
    return r;
  }

  // Exit `code`, no "internal error", and every needle in stderr.
  static void ExpectError(const ProcessResult& r, int code,
                          const std::vector<std::string>& needles) {
    EXPECT_EQ(r.code, code) << r.err;
    EXPECT_FALSE(Contains(r.err, "internal error")) << r.err;
    for (const std::string& n : needles)
      EXPECT_TRUE(Contains(r.err, n)) << "'" << n << "' not in\n" << r.err.substr(0, 3000);
  }

  // The first `n` frames of the dataset `source` (images referenced by path) in dir_/name, with
  // its ground truth when `with_groundtruth`.
  std::string SmallDataset(const std::string& source, size_t n, const std::string& name,
                           bool with_groundtruth = false) {
    const std::filesystem::path dir = std::filesystem::path(dir_) / name;
    std::filesystem::create_directories(dir);
    const RgbdDataset d = RgbdDataset::Open(source);
    std::ofstream rgb(dir / "rgb.txt"), depth(dir / "depth.txt");
    for (size_t i = 0; i < n; ++i) {
      rgb << d.frame(i).rgb_stamp.ToString() << " " << d.frame(i).rgb_path << "\n";
      depth << d.frame(i).depth_stamp.ToString() << " " << d.frame(i).depth_path << "\n";
    }
    if (with_groundtruth) std::filesystem::copy_file(d.groundtruth_path(), dir / "groundtruth.txt");
    return dir.string();
  }

  std::string dir_;  // the test's scratch folder

 private:
  std::string scratch_;
};

}  // namespace dygslam::testing
