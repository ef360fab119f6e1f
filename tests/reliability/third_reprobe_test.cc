// Third re-probe of issue 20 (2026-12-02), the library half: each case failed before its fix.
//   item 2  a settings pipe whose writer stalls mid-file hung without limit and ignored the stop
//           signals (ReadPipeBounded: bounded in total, StopSignalError on SIGINT / SIGTERM)
//   item 4  a truncated .ot was accepted (OctoMap reads what it can)
//   item 6  a detections class_id out of the detector's classes was accepted (1e300: UB cast)
//   item 8  --frames LAST beyond the dataset was cut without a word
//   item 9  range messages showed the C++ check ("requires num_features > 0 && ...")
//   item 10 compared numbers printed alike when they differ in the last bits ("0.5 != 0.5")
//   item 11 an OctoMap header message stopped at a NUL byte
//   item 12 a known key of the wrong type got a spurious unknown-key warning first
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
#include "run/mapping_config.h"
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

// Item 9: every range error reachable from the settings names the file's key and says what is
// expected in the file's keys, never the C++ condition.
TEST(ThirdReprobe, RangeMessagesUseTheFilesKeysNotTheCxxCheck) {
  struct Case {
    std::string text, key, expect;
  };
  const std::vector<Case> cases = {
      {WithFlat("ORBextractor.nFeatures", "0"), "ORBextractor.nFeatures",
       "invalid value 0 (expected nFeatures > 0 and nFeatures <= 100000)"},
      {WithFlat("ORBextractor.nLevels", "0"), "ORBextractor.nLevels", "nLevels >= 1"},
      {WithFlat("ORBextractor.scaleFactor", "1"), "ORBextractor.scaleFactor", "scaleFactor > 1"},
      {WithFlat("ORBextractor.minThFAST", "30"), "ORBextractor.minThFAST",
       "minThFAST <= iniThFAST"},
      {WithFlat("DepthMapFactor", "0"), "DepthMapFactor",
       "DepthMapFactor > 0 and DepthMapFactor finite"},
      {WithFlat("ThDepth", "0"), "ThDepth", "ThDepth > 0"},
      {WithFlat("Camera.fps", "0"), "Camera.fps", "fps > 0"},
      {BonnYaml() + "DynamicFilter:\n  anchor_max_age: 0\n", "DynamicFilter.anchor_max_age",
       "anchor_max_age >= 1"},
      {BonnYaml() + "DynamicFilter:\n  box_margin_fraction: 2\n",
       "DynamicFilter.box_margin_fraction", "box_margin_fraction <= 1"},
      {BonnYaml() + "DynamicFilter:\n  depth_residual_scale: 0\n",
       "DynamicFilter.depth_residual_scale", "depth_residual_scale > 0"},
      {BonnYaml() + "Detector:\n  dynamic_classes: []\n", "Detector.dynamic_classes",
       "dynamic_classes not empty"},
  };
  for (const Case& c : cases) {
    const std::string message = SettingsError(c.text);
    EXPECT_TRUE(Contains(message, "bad.yaml:")) << message;
    EXPECT_TRUE(Contains(message, "key '" + c.key + "'")) << message;
    EXPECT_TRUE(Contains(message, c.expect)) << c.expect << "\n" << message;
    for (const char* cxx : {"requires", "&&", "||", "std::", "num_features", "report_all_classes",
                            ".empty()", "min_th_fast", "depth_map_factor"})
      EXPECT_FALSE(Contains(message, cxx)) << cxx << " in: " << message;
  }
}

TEST(ThirdReprobe, UserConditionRewritesFieldsToKeys) {
  const std::vector<std::string> keys = KnownSettingsKeys();
  EXPECT_EQ(
      UserCondition("num_features > 0 && num_features <= 100000", "ORBextractor.nFeatures", keys),
      "nFeatures > 0 and nFeatures <= 100000");
  EXPECT_EQ(UserCondition("report_all_classes || !dynamic_classes.empty()",
                          "Detector.dynamic_classes", keys),
            "dynamic_classes not empty");
  EXPECT_EQ(UserCondition("clamping_min > 0 && clamping_min < occupancy_threshold",
                          "OctoMap.clamping_min", keys),
            "clamping_min > 0 and clamping_min < occupancy_threshold");
  EXPECT_EQ(UserCondition("min_th_fast > 0 && min_th_fast <= ini_th_fast", "ORBextractor.minThFAST",
                          keys),
            "minThFAST > 0 and minThFAST <= iniThFAST");
  EXPECT_EQ(UserCondition("depth_residual_scale > 0 && std::isfinite(depth_residual_scale)",
                          "DynamicFilter.depth_residual_scale", keys),
            "depth_residual_scale > 0 and depth_residual_scale finite");
}

// Item 12: `Detector.dynamic_classes: {a: 1}` warned "unknown key 'Detector.dynamic_classes.a'"
// before the type error; the type error alone is reported.
TEST(ThirdReprobe, MistypedKnownKeyGetsNoUnknownKeyWarning) {
  std::vector<std::string> warnings;
  const std::string message =
      SettingsError(BonnYaml() + "Detector:\n  dynamic_classes: {a: 1}\n", &warnings);
  EXPECT_TRUE(Contains(message, "key 'Detector.dynamic_classes'")) << message;
  EXPECT_TRUE(warnings.empty()) << warnings.front();
  // A misspelt key is still warned about.
  const Settings misspelt =
      ParseSettings(BonnYaml() + "Detector:\n  dynamic_clases: [person]\n", "bad.yaml");
  ASSERT_EQ(misspelt.warnings.size(), 1u);
  EXPECT_TRUE(Contains(misspelt.warnings[0], "did you mean 'Detector.dynamic_classes'"))
      << misspelt.warnings[0];
}

// Item 10: numbers that differ print differently; the usual ones print as before.
TEST(ThirdReprobe, ComparedNumbersPrintWithTheDigitsThatTellThemApart) {
  const double half = 0.5, forged = std::nextafter(0.5, 1.0);
  EXPECT_NE(ExactNumber(half), ExactNumber(forged));
  EXPECT_EQ(std::strtod(ExactNumber(forged).c_str(), nullptr), forged);
  EXPECT_EQ(ExactNumber(half), "0.5");
  EXPECT_EQ(ExactNumber(542.822841), "542.822841");
  EXPECT_EQ(ExactNumber(0.1), "0.1");
}

// Item 8: --frames beyond the dataset is cut with a note naming --frames and the real count.
TEST(ThirdReprobe, FramesBeyondTheDatasetGiveANote) {
  std::string note;
  EXPECT_EQ(ParseFrameRange("0:5000", 20, &note), (std::pair<size_t, size_t>{0, 20}));
  EXPECT_TRUE(Contains(note, "--frames '0:5000'")) << note;
  EXPECT_TRUE(Contains(note, "20 rgb.txt entries")) << note;
  EXPECT_EQ(ParseFrameRange("2:", 20, &note), (std::pair<size_t, size_t>{2, 20}));
  EXPECT_TRUE(note.empty()) << note;
  EXPECT_EQ(ParseFrameRange("0:20", 20, &note), (std::pair<size_t, size_t>{0, 20}));
  EXPECT_TRUE(note.empty()) << note;
}

// Item 6: class ids outside the detector's classes are errors with file:line.
TEST(ThirdReprobe, DetectionClassIdOutOfRangeIsAnError) {
  const fs::path dir = testing::MakeTempDir("third_reprobe_det");
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

// A small map written as .ot / .bt.
octomap::OcTree SmallTree() {
  octomap::OcTree tree(0.05);
  for (int i = 0; i < 400; ++i)
    tree.updateNode(octomap::point3d(0.05f * (i % 20), 0.05f * (i / 20), 0.3f), i % 3 != 0);
  return tree;
}

// Items 4 and 11: a truncated .ot (or .bt) is an error naming the file; a complete one reads;
// a header with a NUL byte is echoed escaped.
TEST(ThirdReprobe, TruncatedOctoMapIsAnError) {
  const fs::path dir = testing::MakeTempDir("third_reprobe_ot");
  octomap::OcTree tree = SmallTree();
  const std::string ot = (dir / "map.ot").string(), bt = (dir / "map.bt").string();
  ASSERT_TRUE(tree.write(ot));
  ASSERT_TRUE(tree.writeBinary(bt));
  EXPECT_EQ(ReadOctoMap(ot)->size(), tree.size());
  EXPECT_GT(ReadOctoMap(bt)->size(), 0u);
  for (const std::string& full : {ot, bt}) {
    const std::string bytes = testing::ReadAll(full);
    for (const double share : {0.5, 0.9}) {
      const std::string cut = full + ".cut";
      std::ofstream(cut, std::ios::binary)
          << bytes.substr(0, static_cast<size_t>(bytes.size() * share));
      try {
        ReadOctoMap(cut);
        ADD_FAILURE() << "truncated " << full << " at " << share << " accepted";
      } catch (const InputError& e) {
        EXPECT_TRUE(Contains(e.what(), cut)) << e.what();
        EXPECT_TRUE(Contains(e.what(), "truncated or corrupt")) << e.what();
      }
    }
  }
  const std::string nul = (dir / "nul.ot").string();
  std::ofstream(nul, std::ios::binary) << std::string("# Octo\0map junk after\n", 22);
  try {
    ReadOctoMap(nul);
    ADD_FAILURE() << "accepted";
  } catch (const InputError& e) {
    EXPECT_TRUE(Contains(e.what(), "# Octo\\x00map junk")) << e.what();
  }
}

// A crafted OctoMap whose nodes nest a million levels deep (each node's only child is the next
// node; OctoMap's trees have 16 levels): OctoMap's readers recurse once per level and overflowed
// the stack (SIGSEGV). Now an error naming the file and the depth, for .ot and .bt; a valid map
// of the full 16 levels still reads.
TEST(ThirdReprobe, DeeplyNestedOctoMapIsAnError) {
  const fs::path dir = testing::MakeTempDir("third_reprobe_deep");
  constexpr long long kNodes = 1000000;
  const std::string ot = (dir / "deep.ot").string(), bt = (dir / "deep.bt").string();
  {
    std::ofstream out(ot, std::ios::binary);
    out << "# Octomap OcTree file\nid OcTree\nsize " << kNodes << "\nres 0.05\ndata\n";
    std::string record(5, '\0');
    const float value = 0.5f;
    std::memcpy(record.data(), &value, sizeof(value));
    for (long long k = 0; k < kNodes; ++k) {
      record[4] = k + 1 < kNodes ? '\x01' : '\0';  // child 0 is the next node
      out << record;
    }
  }
  {
    std::ofstream out(bt, std::ios::binary);
    out << "# Octomap OcTree binary file\nid OcTree\nsize " << kNodes << "\nres 0.05\ndata\n";
    for (long long k = 0; k < kNodes; ++k) {
      out << (k + 1 < kNodes ? '\x03' : '\x00') << '\0';  // 11: child 0 has children
    }
  }
  for (const std::string& path : {ot, bt}) {
    try {
      ReadOctoMap(path);
      ADD_FAILURE() << path << " accepted";
    } catch (const InputError& e) {
      EXPECT_TRUE(Contains(e.what(), path)) << e.what();
      EXPECT_TRUE(Contains(e.what(), "deeper than the tree's 16 levels")) << e.what();
    }
  }
  // A map with a voxel at the finest level (16 levels, the deepest valid nesting) reads back whole.
  octomap::OcTree tree(0.05);
  tree.updateNode(octomap::point3d(0.3f, -0.2f, 1.1f), true);
  tree.updateNode(octomap::point3d(-1.f, 0.4f, 0.2f), false);
  const std::string ot_ok = (dir / "ok.ot").string(), bt_ok = (dir / "ok.bt").string();
  ASSERT_TRUE(tree.write(ot_ok));
  ASSERT_TRUE(tree.writeBinary(bt_ok));
  EXPECT_EQ(ReadOctoMap(ot_ok)->size(), tree.size());
  EXPECT_GT(ReadOctoMap(bt_ok)->size(), 0u);
  // An empty tree has no node data and reads as empty.
  const std::string empty = (dir / "empty.bt").string(), empty_ot = (dir / "empty.ot").string();
  ASSERT_TRUE(octomap::OcTree(0.05).writeBinary(empty));
  ASSERT_TRUE(octomap::OcTree(0.05).write(empty_ot));
  EXPECT_EQ(ReadOctoMap(empty)->size(), 0u);
  EXPECT_EQ(ReadOctoMap(empty_ot)->size(), 0u);
  // A node count other than the header's is an error too.
  std::string bytes = testing::ReadAll(ot_ok);
  const size_t size_at = bytes.find("size ");
  ASSERT_NE(size_at, std::string::npos);
  bytes.replace(size_at, bytes.find('\n', size_at) - size_at, "size 3");
  const std::string ot_count = (dir / "count.ot").string();
  std::ofstream(ot_count, std::ios::binary) << bytes;
  try {
    ReadOctoMap(ot_count);
    ADD_FAILURE() << "a wrong node count accepted";
  } catch (const InputError& e) {
    EXPECT_TRUE(Contains(e.what(), "truncated or corrupt")) << e.what();
    EXPECT_TRUE(Contains(e.what(), "declares 3 nodes")) << e.what();
  }
}

// Item 2: a writer that sends half the file and stalls: the read ends after the bounded wait
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

TEST(ThirdReprobe, StalledPipeWriterEndsAfterTheBoundedWait) {
  const fs::path dir = testing::MakeTempDir("third_reprobe_fifo");
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

TEST(ThirdReprobe, StopSignalEndsAPipeReadAtOnce) {
  const fs::path dir = testing::MakeTempDir("third_reprobe_fifo_signal");
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
