// A settings file that is a pipe (ReadPipeBounded): a writer that stalls mid-file ends the read
// after the bounded wait, and SIGINT / SIGTERM end it at once (StopSignalError).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <octomap/OcTree.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "core/base/echo.h"
#include "core/base/error.h"
#include "core/base/input_file.h"
#include "core/base/stop_signal.h"
#include "core/config/config_reader.h"
#include "core/config/settings.h"
#include "core/io/dataset.h"
#include "core/io/detections_io.h"
#include "mapping/octomap_builder.h"
#include "mapping/octomap_settings.h"
#include "run/settings_table.h"
#include "run/system_config.h"
#include "tests/support/test_support.h"

namespace dygslam {
namespace {
namespace fs = std::filesystem;

std::string BonnYaml() {
  std::ifstream in(std::string(DYGSLAM_TEST_SOURCE_DIR) + "/config/bonn.yaml");
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

bool Contains(const std::string& text, const std::string& needle) {
  return text.find(needle) != std::string::npos;
}

// The InputError of reading `text` the way `dygslam run` does ("" and a failure if accepted).
std::string SettingsError(const std::string& text, std::vector<std::string>* warnings = nullptr) {
  try {
    const Settings settings = ParseSettings(text, "bad.yaml");
    if (warnings != nullptr) *warnings = settings.warnings;
    SystemOptionsFromSettings(settings);
    OctoMapOptions octomap;
    ReadOptions(settings.reader, &octomap);
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "accepted:\n" << text.substr(text.size() > 200 ? text.size() - 200 : 0);
  return "";
}

// bonn.yaml with `line` replaced (flat ORB-SLAM2 keys) or a section appended.
std::string WithFlat(const std::string& key, const std::string& value) {
  std::string text = BonnYaml();
  const size_t at = text.find("\n" + key + ":");
  EXPECT_NE(at, std::string::npos) << key;
  const size_t end = text.find('\n', at + 1);
  text.replace(at + 1, end - at - 1, key + ": " + value);
  return text;
}

// A writer that sends half the file and stalls: the read ends after the bounded wait
// (it hung without limit), and a stop signal ends it at once (it was ignored).
class StalledWriter {
 public:
  StalledWriter(const std::string& fifo, const std::string& half) {
    thread_ = std::thread([this, fifo, half] {
      int fd = -1;
      // Non-blocking open fails (ENXIO) until the reader has opened the FIFO.
      for (int k = 0; k < 500 && fd < 0 && !done_; ++k) {
        fd = ::open(fifo.c_str(), O_WRONLY | O_NONBLOCK);
        if (fd < 0) std::this_thread::sleep_for(std::chrono::milliseconds(10));
      }
      if (fd < 0) return;
      (void)!::write(fd, half.data(), half.size());
      while (!done_) std::this_thread::sleep_for(std::chrono::milliseconds(10));
      ::close(fd);
    });
  }
  ~StalledWriter() {
    done_ = true;
    thread_.join();
  }

 private:
  std::atomic<bool> done_{false};
  std::thread thread_;
};

TEST(SettingsPipeSignals, StalledPipeWriterEndsAfterTheBoundedWait) {
  const fs::path dir = testing::MakeTempDir("signals_settings_pipe_fifo");
  const std::string fifo = (dir / "settings.yaml").string();
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  const std::string yaml = BonnYaml();
  StalledWriter writer(fifo, yaml.substr(0, yaml.size() / 2));
  const auto t0 = std::chrono::steady_clock::now();
  try {
    ReadPipeBounded(fifo, 1 << 20, "settings file", 1.0);
    ADD_FAILURE() << "a stalled writer's half file was read as the whole";
  } catch (const InputError& e) {
    EXPECT_TRUE(Contains(e.what(), fifo + ": settings file is a pipe (FIFO) whose writer did not "
                                          "finish within 1 s"))
        << e.what();
    EXPECT_TRUE(Contains(e.what(), "stalled")) << e.what();
  }
  const double waited =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_GE(waited, 0.9);
  EXPECT_LT(waited, 5.0);
}

TEST(SettingsPipeSignals, StopSignalEndsAPipeReadAtOnce) {
  const fs::path dir = testing::MakeTempDir("signals_settings_pipe_fifo_signal");
  const std::string fifo = (dir / "settings.yaml").string();
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  const std::string yaml = BonnYaml();
  for (const bool with_writer : {false, true}) {
    std::optional<StalledWriter> writer;
    if (with_writer) writer.emplace(fifo, yaml.substr(0, yaml.size() / 2));
    ScopedStopSignals signals;  // as `dygslam run` from its first moment
    std::thread killer([] {
      std::this_thread::sleep_for(std::chrono::milliseconds(300));
      ::kill(::getpid(), SIGTERM);
    });
    const auto t0 = std::chrono::steady_clock::now();
    try {
      ReadPipeBounded(fifo, 1 << 20, "settings file", 20.0);
      ADD_FAILURE() << "read";
    } catch (const StopSignalError& e) {
      EXPECT_EQ(e.exit_code(), 143);
      EXPECT_TRUE(Contains(e.what(), fifo)) << e.what();
    }
    killer.join();
    const double waited =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    EXPECT_LT(waited, 3.0) << "with_writer " << with_writer;  // not the 20 s wait
  }
}

}  // namespace
}  // namespace dygslam
