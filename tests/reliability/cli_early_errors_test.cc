// Errors before any work: 100 kB values of --domain / --listen / --partition are echoed bounded;
// `run --direct` and `map` whose filter needs the detector fail before any output when no model
// is found.
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

class CliEarlyErrors : public testing::CliFixture {
 protected:
  CliEarlyErrors() : CliFixture("cli_early_errors") {}

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

// Megabyte-long option values are echoed bounded.
TEST_F(CliEarlyErrors, LongOptionValuesAreEchoedBounded) {
  const std::string huge(100000, '7');
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"run", dir_, "--config", Config(), "--out", dir_ + "/o",
                                 "--domain", huge},
        std::vector<std::string>{"run", dir_, "--config", Config(), "--out", dir_ + "/o",
                                 "--loop-minutes", huge + "x"},
        std::vector<std::string>{"discovery-server", "--listen", huge},
        std::vector<std::string>{"discovery-server", "--listen", "127.0.0.1:7400", "--domain",
                                 huge + "x"}}) {
    const auto r = Run(args);
    EXPECT_EQ(r.code, 2) << r.err.substr(0, 500);
    EXPECT_LT(r.err.size(), 3000u) << args[0] << " " << args[args.size() - 2];
    EXPECT_TRUE(Contains(r.err, "(100000 bytes)") || Contains(r.err, "(100001 bytes)"))
        << r.err.substr(0, 800);
  }
}

// No models: the run fails before writing anything (it wrote four empty outputs).
TEST_F(CliEarlyErrors, NoModelsFailsBeforeAnyOutput) {
  DYGSLAM_REQUIRE_DATASET(source, "bonn_crowd_part");
  const std::string dataset = SmallDataset(source, 5, "nomodels");
  const std::string no_models = dir_ + "/no_models";
  fs::create_directories(no_models);
  ::setenv("DYGSLAM_MODELS_DIR", no_models.c_str(), 1);
  const auto run =
      Run({"run", dataset, "--config", Config(), "--out", dir_ + "/o_run", "--direct", "--quiet"});
  const auto map = Run({"map", dataset, "--config", Config(), "--out", dir_ + "/o_map", "--quiet"});
  ::unsetenv("DYGSLAM_MODELS_DIR");
  for (const auto* r : {&run, &map}) ExpectError(*r, 1, {"yolo-fastest-1.1"});
  EXPECT_FALSE(fs::exists(dir_ + "/o_run")) << run.err;
  EXPECT_FALSE(fs::exists(dir_ + "/o_map")) << map.err;
}

}  // namespace
}  // namespace dygslam
