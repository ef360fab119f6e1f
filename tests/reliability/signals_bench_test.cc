// `dygslam bench` stopped by SIGINT / SIGTERM writes runs.csv and the report of the runs that
// ended before the signal (the interrupted run left out, the report says so).
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/types.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "core/io/dataset.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

std::string Config() { return std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/bonn.yaml"; }

bool Contains(const std::string& text, const std::string& needle) {
  return text.find(needle) != std::string::npos;
}

class BenchSignals : public ::testing::Test {
 protected:
  void SetUp() override {
    DYGSLAM_REQUIRE_FILE(testing::DygslamBinary(), "dygslam binary");
    dir_ = testing::MakeTempDir("signals_bench");
  }
  void TearDown() override { fs::remove_all(dir_); }
  testing::ProcessResult Run(const std::vector<std::string>& args) {
    return testing::RunDygslam(args, dir_);
  }
  static void ExpectError(const testing::ProcessResult& r, int code,
                          const std::vector<std::string>& needles) {
    EXPECT_EQ(r.code, code) << r.err;
    EXPECT_FALSE(Contains(r.err, "internal error")) << r.err;
    for (const std::string& n : needles)
      EXPECT_TRUE(Contains(r.err, n)) << "'" << n << "' not in\n" << r.err.substr(0, 3000);
  }
  // The first `n` frames of bonn_crowd_part (images by absolute path) in dir_/name.
  std::string SmallDataset(const std::string& source, size_t n, const std::string& name) {
    const fs::path dir = fs::path(dir_) / name;
    fs::create_directories(dir);
    const RgbdDataset d = RgbdDataset::Open(source);
    std::ofstream rgb(dir / "rgb.txt"), depth(dir / "depth.txt");
    for (size_t i = 0; i < n; ++i) {
      rgb << d.frame(i).rgb_stamp.ToString() << " " << d.frame(i).rgb_path << "\n";
      depth << d.frame(i).depth_stamp.ToString() << " " << d.frame(i).depth_path << "\n";
    }
    fs::copy_file(d.groundtruth_path(), dir / "groundtruth.txt");
    return dir.string();
  }
  std::string dir_;
};

// A stop signal between runs writes the report of the runs done, exit 0.
TEST_F(BenchSignals, BenchStoppedBySignalWritesTheRunsDone) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string ds = SmallDataset(source, 8, "ds");
  const std::string out = dir_ + "/b";
  const pid_t pid =
      testing::SpawnDygslam({"bench", ds, "--runs", "3", "--configs", "none", "--no-baseline",
                             "--no-pictures", "--out", out, "--deterministic"},
                            dir_ + "/bench.out", dir_ + "/bench.err");
  ASSERT_GT(pid, 0);
  // Run 1 is scored once its line ("... ATE RMSE ...") is printed: stop the bench after it.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (!Contains(testing::ReadAll(dir_ + "/bench.err"), "ATE RMSE") &&
         std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  ASSERT_TRUE(Contains(testing::ReadAll(dir_ + "/bench.err"), "ATE RMSE"))
      << testing::ReadAll(dir_ + "/bench.err");
  ::kill(pid, SIGTERM);
  std::string diagnostics;
  const int code = testing::WaitForExit(pid, 120, &diagnostics);
  const std::string err = testing::ReadAll(dir_ + "/bench.err");
  EXPECT_EQ(code, 0) << err << diagnostics;
  EXPECT_TRUE(Contains(err, "stopped by signal 15 after 1 of 3 runs")) << err;
  const std::string csv = testing::ReadAll(out + "/runs.csv");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 2) << "header + run 1:\n" << csv;
  EXPECT_TRUE(Contains(testing::ReadAll(out + "/report.md"), "stopped by signal 15"));
}

}  // namespace
}  // namespace dygslam
