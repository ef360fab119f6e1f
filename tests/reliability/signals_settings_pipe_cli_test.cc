// Ctrl-C / SIGTERM while `dygslam` waits for a settings pipe (no writer, or a writer stalled
// mid-file) ends the command at once with 128 + the signal, nothing written.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "core/base/stop_signal.h"
#include "core/io/dataset.h"
#include "core/io/trajectory_io.h"
#include "tests/support/cli_fixture.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

using testing::Contains;

class SettingsPipeStop : public testing::CliFixture {
 protected:
  SettingsPipeStop() : CliFixture("signals_settings_pipe_cli") {}

  // Replaces rgb.txt entry `entry`'s image by a truncated copy named broken.png.
  void BreakImage(const std::string& dataset, size_t entry) {
    const RgbdDataset d = RgbdDataset::Open(dataset);
    const std::string bytes = testing::ReadAll(d.frame(entry).rgb_path);
    std::ofstream(dataset + "/broken.png", std::ios::binary) << bytes.substr(0, bytes.size() / 3);
    std::string rgb = testing::ReadAll(dataset + "/rgb.txt");
    const std::string old_path = d.frame(entry).rgb_path;
    rgb.replace(rgb.find(old_path), old_path.size(), "broken.png");
    std::ofstream(dataset + "/rgb.txt") << rgb;
  }
};

// A stop signal while the settings pipe is waited for ends the command at once with
// 128 + signal, nothing written (the --out folder it made is removed).
TEST_F(SettingsPipeStop, StopSignalWhileReadingASettingsPipe) {
  const std::string yaml = testing::ReadAll(Config());
  for (const int sig : {SIGINT, SIGTERM}) {
    const std::string fifo = dir_ + "/settings_" + std::to_string(sig) + ".yaml";
    ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
    // SIGTERM: a writer that sends half the file and stalls; SIGINT: no writer at all.
    std::thread writer;
    std::atomic<bool> done{false};
    if (sig == SIGTERM) {
      writer = std::thread([&] {
        int fd = -1;
        for (int k = 0; k < 1000 && fd < 0 && !done; ++k) {
          fd = ::open(fifo.c_str(), O_WRONLY | O_NONBLOCK);
          if (fd < 0) std::this_thread::sleep_for(std::chrono::milliseconds(10));
        }
        if (fd < 0) return;
        (void)!::write(fd, yaml.data(), yaml.size() / 2);
        while (!done) std::this_thread::sleep_for(std::chrono::milliseconds(10));
        ::close(fd);
      });
    }
    const std::string out = dir_ + "/pipe_out_" + std::to_string(sig);
    const pid_t pid = testing::SpawnDygslam({"run", dir_, "--config", fifo, "--out", out},
                                            dir_ + "/pipe.out", dir_ + "/pipe.err");
    for (int k = 0; k < 500 && !ProcessCatchesSignal(pid, sig); ++k)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    std::this_thread::sleep_for(std::chrono::milliseconds(500));  // in the wait by now
    const auto t0 = std::chrono::steady_clock::now();
    ::kill(pid, sig);
    std::string diagnostics;
    const int code = testing::WaitForExit(pid, 10.0, &diagnostics);
    const double took =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    done = true;
    if (writer.joinable()) writer.join();
    const std::string err = testing::ReadAll(dir_ + "/pipe.err") + diagnostics;
    EXPECT_EQ(code, 128 + sig) << err;
    EXPECT_LT(took, 3.0) << err;
    EXPECT_TRUE(Contains(err, fifo)) << err;
    EXPECT_FALSE(fs::exists(out)) << "an empty --out folder left behind";
  }
}

}  // namespace
}  // namespace dygslam
