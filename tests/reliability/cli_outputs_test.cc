// Output files and folders of the commands: an output that exists as a device or a FIFO is
// refused and left as it was (an atomic write would rename over it); an --out folder removed while
// the command runs is made again, with a warning, and every output is written.
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

class CliOutputFiles : public testing::CliFixture {
 protected:
  CliOutputFiles() : CliFixture("cli_outputs") {}
  void TearDown() override { fs::remove_all(dir_); }
};

// A FIFO (or a device) named as an output file is refused and left as it was.
TEST_F(CliOutputFiles, OutputFileThatIsAFifoIsLeftAlone) {
  const std::string fifo = dir_ + "/out.fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  // eval --save-aligned: ground truth against a copy of itself (a valid evaluation).
  std::ofstream(dir_ + "/gt.txt") << "1 0 0 0 0 0 0 1\n2 1 0 0 0 0 0 1\n3 1 1 0 0 0 0 1\n"
                                  << "4 0 1 1 0 0 0 1\n";
  fs::copy_file(dir_ + "/gt.txt", dir_ + "/est.txt");
  const auto r = Run({"eval", dir_ + "/gt.txt", dir_ + "/est.txt", "--save-aligned", fifo});
  ExpectError(r, 1, {fifo, "a FIFO, not a regular file"});
  EXPECT_TRUE(fs::is_fifo(fifo)) << "the FIFO was replaced";
  // vocab OUT_FILE: the smallest vocabulary, refused before or after training, never renamed over.
  const auto v = Run({"vocab", fifo, "--scenes", "1", "--frames-per-scene", "1", "--depth", "1",
                      "--branching", "2", "--quiet"});
  ExpectError(v, 1, {"a FIFO, not a regular file"});
  EXPECT_TRUE(fs::is_fifo(fifo)) << "the FIFO was replaced";
  for (const auto& entry : fs::directory_iterator(dir_))
    EXPECT_FALSE(Contains(entry.path().filename().string(), ".tmp.")) << entry.path();
}

// --out removed while the run goes: made again, said, every output written.
TEST_F(CliOutputFiles, OutFolderRemovedMidRunIsMadeAgain) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string ds = SmallDataset(source, 60, "ds", /*with_groundtruth=*/true);
  for (const std::string command : {"run", "map"}) {
    const std::string out = dir_ + "/o_" + command;
    std::vector<std::string> args = {command, ds,        "--config", Config(), "--out",
                                     out,     "--quiet", "--filter", "none"};
    if (command == "run") args.push_back("--direct");
    const pid_t pid = testing::SpawnDygslam(args, out + ".out", out + ".err");
    ASSERT_GT(pid, 0);
    // The folder is made before the first frame and checked for writing with a probe file that
    // is removed at once; remove the folder when the probe has gone (removing it while the
    // command writes its probe is a different case: the folder is then not writable).
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    auto probing = [&] {
      std::error_code ec;
      for (const auto& entry : fs::directory_iterator(out, ec))
        if (Contains(entry.path().filename().string(), "write_probe")) return true;
      return false;
    };
    while ((!fs::exists(out) || probing()) && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    ASSERT_TRUE(fs::exists(out)) << command;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    std::error_code ec;
    fs::remove_all(out, ec);
    ASSERT_FALSE(fs::exists(out)) << command << ": " << ec.message();
    std::string diagnostics;
    const int code = testing::WaitForExit(pid, 300, &diagnostics);
    const std::string err = testing::ReadAll(out + ".err");
    EXPECT_EQ(code, 0) << command << ": " << err << diagnostics;
    EXPECT_TRUE(Contains(err, "--out '" + out + "' was removed while the command ran")) << err;
    const std::string trajectory = testing::ReadAll(out + "/trajectory.txt");
    EXPECT_GE(std::count(trajectory.begin(), trajectory.end(), '\n'), 50) << command;
  }
}

}  // namespace
}  // namespace dygslam
