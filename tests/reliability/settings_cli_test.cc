// Settings files through the command line: a second YAML document and a merge key are errors of
// `dygslam run` naming the file and line (their keys would otherwise be dropped).
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

class SettingsCli : public testing::CliFixture {
 protected:
  SettingsCli() : CliFixture("settings_cli") {}
  void TearDown() override { fs::remove_all(dir_); }
};

// A second document or a merge key in a settings file is an error of `run` with the line.
TEST_F(SettingsCli, SettingsDocumentsAndMergeKeysAreErrors) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string ds = SmallDataset(source, 4, "ds", /*with_groundtruth=*/true);
  const std::string bonn = testing::ReadAll(Config());
  const int lines = static_cast<int>(std::count(bonn.begin(), bonn.end(), '\n'));
  std::ofstream(dir_ + "/two.yaml") << bonn << "---\nCamera.fx: 500\n";
  ExpectError(Run({"run", ds, "--config", dir_ + "/two.yaml", "--out", dir_ + "/o", "--direct"}), 1,
              {"two.yaml:" + std::to_string(lines + 2) + ":", "second YAML document"});
  std::ofstream(dir_ + "/merge.yaml")
      << bonn << "base: &b {alpha: 0.9}\nDynamicFilter:\n  <<: *b\n";
  ExpectError(Run({"run", ds, "--config", dir_ + "/merge.yaml", "--out", dir_ + "/o", "--direct"}),
              1, {"merge.yaml:" + std::to_string(lines + 3) + ":", "merge key"});
  EXPECT_FALSE(fs::exists(dir_ + "/o")) << "a failed run left its --out folder";
}

}  // namespace
}  // namespace dygslam
