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
#include "tests/support/cli_fixture.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

using testing::Contains;

class BenchSignals : public testing::CliFixture {
 protected:
  BenchSignals() : CliFixture("signals_bench") {}
  void TearDown() override { fs::remove_all(dir_); }
};

// A stop signal between runs writes the report of the runs done, exit 0.
TEST_F(BenchSignals, BenchStoppedBySignalWritesTheRunsDone) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string ds = SmallDataset(source, 8, "ds", /*with_groundtruth=*/true);
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
