// `dygslam run` on a dataset with a broken frame in the middle (a truncated PNG, as left by a
// full disk or an interrupted copy): either a clear error naming the file (exit 1), or a counted
// skip with the trajectory of the other frames written -- never a crash (signal) or a silent
// success that hides the frame.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "core/io/dataset.h"
#include "core/io/trajectory_io.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

std::string Binary() {
  if (const char* dir = std::getenv("DYGSLAM_BINARY_DIR"))
    return std::string(dir) + "/apps/dygslam";
  const fs::path self = fs::read_symlink("/proc/self/exe");
  return (self.parent_path().parent_path().parent_path() / "apps" / "dygslam").string();
}

std::string ReadAll(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Runs argv with stdout/stderr to files; returns the exit code (128 + signal if killed).
int RunCommand(const std::vector<std::string>& args, const std::string& out,
               const std::string& err) {
  const pid_t pid = fork();
  if (pid == 0) {
    std::vector<std::string> copy = args;
    std::vector<char*> argv;
    for (auto& a : copy) argv.push_back(a.data());
    argv.push_back(nullptr);
    if (!std::freopen(out.c_str(), "w", stdout) || !std::freopen(err.c_str(), "w", stderr))
      std::_Exit(126);
    execv(argv[0], argv.data());
    std::_Exit(127);
  }
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

class CliBadInput : public ::testing::TestWithParam<std::string> {};

TEST_P(CliBadInput, TruncatedFrameMidRunIsAClearErrorOrACountedSkip) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  DYGSLAM_REQUIRE_FILE(Binary(), "dygslam binary");
  // A 30-frame copy of the dataset (images linked, frame 15's colour image truncated).
  const fs::path dir = testing::MakeTempDir("cli_truncated");
  const RgbdDataset d = RgbdDataset::Open(source);
  fs::create_directories(dir / "rgb");
  fs::create_directories(dir / "depth");
  std::ofstream rgb_list(dir / "rgb.txt"), depth_list(dir / "depth.txt");
  std::string broken;
  for (size_t i = 0; i < 30; ++i) {
    const RgbdFrameEntry& f = d.frame(i);
    const fs::path rgb = dir / "rgb" / fs::path(f.rgb_path).filename();
    const fs::path depth = dir / "depth" / fs::path(f.depth_path).filename();
    if (i == 15) {
      const std::string bytes = ReadAll(f.rgb_path);
      std::ofstream(rgb, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
      broken = rgb.filename().string();
    } else {
      fs::create_symlink(f.rgb_path, rgb);
    }
    fs::create_symlink(f.depth_path, depth);
    rgb_list << f.rgb_stamp.ToString() << " rgb/" << rgb.filename().string() << "\n";
    depth_list << f.depth_stamp.ToString() << " depth/" << depth.filename().string() << "\n";
  }
  rgb_list.close();
  depth_list.close();
  const fs::path out = dir / "out";
  std::vector<std::string> args = {Binary(),
                                   "run",
                                   dir.string(),
                                   "--config",
                                   std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/bonn.yaml",
                                   "--filter",
                                   "none",
                                   "--out",
                                   out.string(),
                                   "--quiet",
                                   "--domain",
                                   "131"};
  if (!GetParam().empty()) args.push_back(GetParam());
  const int code = RunCommand(args, (dir / "stdout.txt").string(), (dir / "stderr.txt").string());
  const std::string stdout_text = ReadAll((dir / "stdout.txt").string());
  const std::string stderr_text = ReadAll((dir / "stderr.txt").string());
  ASSERT_LT(code, 128) << "dygslam run was killed by signal " << code - 128 << "\n" << stderr_text;
  if (code != 0) {
    // A clear error naming the broken file.
    EXPECT_EQ(code, 1);
    EXPECT_NE(stderr_text.find(broken), std::string::npos) << stderr_text;
    EXPECT_NE(stderr_text.find("error"), std::string::npos) << stderr_text;
    // What was built before the broken frame is kept, when written at all, loadable.
    if (fs::exists(out / "trajectory.txt")) {
      RecordProperty("frames_kept",
                     static_cast<int>(ReadTumTrajectory((out / "trajectory.txt").string()).size()));
    }
  } else {
    // A counted skip: the broken frame is reported and the others are in the trajectory.
    EXPECT_NE((stdout_text + stderr_text).find(broken), std::string::npos)
        << stdout_text << stderr_text;
    const auto trajectory = ReadTumTrajectory((out / "trajectory.txt").string());
    EXPECT_GE(trajectory.size(), 25u);
    EXPECT_LE(trajectory.size(), 29u);
  }
}

// --processes: a failed player must not leave the other four components waiting for an end of
// stream that never comes (a hang; Ctrl-C would then give rc 0).
INSTANTIATE_TEST_SUITE_P(Modes, CliBadInput,
                         ::testing::Values(std::string(), std::string("--direct"),
                                           std::string("--processes")),
                         [](const ::testing::TestParamInfo<std::string>& info) {
                           if (info.param.empty()) return std::string("Pipeline");
                           return info.param == "--direct" ? std::string("Direct")
                                                           : std::string("Processes");
                         });

}  // namespace
}  // namespace dygslam
