// Dataset lists read by the library: --frames beyond the dataset gives a note naming the number
// of rgb.txt entries, and a detections list whose class_id is not a class of the detector is an
// error naming the file and line.
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

// --frames beyond the dataset is cut with a note naming --frames and the real count.
TEST(DatasetLists, FramesBeyondTheDatasetGiveANote) {
  std::string note;
  EXPECT_EQ(ParseFrameRange("0:5000", 20, &note), (std::pair<size_t, size_t>{0, 20}));
  EXPECT_TRUE(Contains(note, "--frames '0:5000'")) << note;
  EXPECT_TRUE(Contains(note, "20 rgb.txt entries")) << note;
  EXPECT_EQ(ParseFrameRange("2:", 20, &note), (std::pair<size_t, size_t>{2, 20}));
  EXPECT_TRUE(note.empty()) << note;
  EXPECT_EQ(ParseFrameRange("0:20", 20, &note), (std::pair<size_t, size_t>{0, 20}));
  EXPECT_TRUE(note.empty()) << note;
}

// Class ids outside the detector's classes are errors with file:line.
TEST(DatasetLists, DetectionClassIdOutOfRangeIsAnError) {
  const fs::path dir = testing::MakeTempDir("datasets_lists_det");
  const std::string path = (dir / "det.txt").string();
  std::ofstream(path)
      << "# t x y w h class score\n1.0 10 10 50 50 0 0.9\n1.1 10 10 50 50 999 0.9\n";
  try {
    ReadDetections(path, 80, "coco.names");
    ADD_FAILURE() << "class 999 accepted";
  } catch (const InputError& e) {
    EXPECT_TRUE(Contains(e.what(), path + ":3")) << e.what();
    EXPECT_TRUE(Contains(e.what(), "class_id 999")) << e.what();
    EXPECT_TRUE(Contains(e.what(), "0..79")) << e.what();
  }
  EXPECT_EQ(ReadDetections(path).size(), 2u);  // without a class list: any id up to 999999
  std::ofstream(path) << "1.0 10 10 50 50 1e300 0.9\n";
  EXPECT_THROW(ReadDetections(path), InputError);
}

}  // namespace
}  // namespace dygslam
