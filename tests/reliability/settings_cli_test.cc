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
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

std::string Config() { return std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/bonn.yaml"; }

bool Contains(const std::string& text, const std::string& needle) {
  return text.find(needle) != std::string::npos;
}

class SettingsCli : public ::testing::Test {
 protected:
  void SetUp() override {
    DYGSLAM_REQUIRE_FILE(testing::DygslamBinary(), "dygslam binary");
    dir_ = testing::MakeTempDir("settings_cli");
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

// A second document or a merge key in a settings file is an error of `run` with the line.
TEST_F(SettingsCli, SettingsDocumentsAndMergeKeysAreErrors) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string ds = SmallDataset(source, 4, "ds");
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
